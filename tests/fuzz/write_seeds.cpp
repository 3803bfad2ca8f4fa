// Writes the fuzzer's seed corpus: one valid frame of every message type
// (the bytes after the u32 length, which is what decode() and the fuzz
// target take), one file each, into the directory given as argument.
#include <cstdio>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "net/wire.h"

using namespace peis::wire;

namespace {

template <typename M>
std::string body(const M& message) {
  std::string out;
  encode(message, out);
  return out.substr(kFrameHeaderBytes);
}

peis::Tuple tuple(peis::Encoding encoding, std::string data) {
  peis::Tuple t;
  t.owner = 7;
  t.creator = 9;
  t.key = "robot.position.x";
  t.data = std::move(data);
  t.mimetype = encoding == peis::Encoding::Binary ? "application/octet-stream" : "text/plain";
  t.encoding = encoding;
  t.ts_write = peis::Timestamp(std::chrono::microseconds(1'700'000'000'000'000));
  t.seqno = 3;
  return t;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s DIRECTORY\n", argv[0]);
    return 2;
  }
  const Envelope env{7, 3, kDefaultTtl};
  Hello hello;
  hello.ecology = "lab";
  hello.id = 7;
  hello.incarnation = 1'700'000'000'000'000;
  hello.name = "astrid";
  hello.listenPort = 4711;
  hello.capabilities = kCapabilityCoalescing;
  const std::vector<std::pair<std::string, std::string>> seeds = {
      {"hello", body(LinkMessage{hello})},
      {"ping", body(LinkMessage{Ping{42}})},
      {"pong", body(LinkMessage{Pong{42}})},
      {"routes", body(LinkMessage{Routes{{{7, 0, 0, 70, 3, "astrid"}, {8, 2, 1, 80, 0, ""}}}})},
      {"id-taken", body(LinkMessage{IdTaken{7, 70}})},
      {"auth", body(LinkMessage{Auth{std::string(200, 'i'), std::string(64, 's')}})},
      {"identity", body(LinkMessage{Identity{std::string(200, 'i')}})},
      {"source-tag", body(LinkMessage{SourceTag{std::string(16, 't')}})},
      {"subscribe-owner", body(RoutedMessage{env, Subscribe{1, 6000, 7, "robot.*.x"}})},
      {"subscribe-any", body(RoutedMessage{env, Subscribe{2, 6000, std::nullopt, "**"}})},
      {"unsubscribe", body(RoutedMessage{env, Unsubscribe{1}})},
      {"update-text",
       body(RoutedMessage{env, TupleUpdate{70, tuple(peis::Encoding::Ascii, "3.25")}})},
      {"update-binary",
       body(RoutedMessage{
           env, TupleUpdate{70, tuple(peis::Encoding::Binary, std::string("\0\1\2\0", 4))}})},
      {"deleted", body(RoutedMessage{env, TupleDeleted{70, 7, "robot.position.x", 4}})},
      {"write-set", body(RoutedMessage{env, Write{5, WriteOp::Set, std::nullopt, 1000,
                                                  tuple(peis::Encoding::Ascii, "on")}})},
      {"write-append", body(RoutedMessage{env, Write{6, WriteOp::Append, 3u, 0,
                                                     tuple(peis::Encoding::Ascii, "+")}})},
      {"write-result", body(RoutedMessage{env, WriteResult{6, 7, 0, "conflict"}})},
      {"withheld", body(RoutedMessage{
                       env, TupleWithheld{70, 3, 1000, 5000, tuple(peis::Encoding::Ascii, "")}})},
  };
  for (const auto& [name, bytes] : seeds) {
    std::ofstream file(std::string(argv[1]) + "/" + name, std::ios::binary);
    file.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!file) {
      std::fprintf(stderr, "cannot write %s/%s\n", argv[1], name.c_str());
      return 1;
    }
  }
  return 0;
}
