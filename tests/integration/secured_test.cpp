// Secured ecologies (issue 13): PEIS with credentials of one trust root link
// over authenticated, encrypted links; everybody else is refused with the
// reason, whatever they try — no credentials, another root, a forged or
// replayed handshake, an authenticated peer announcing names, ids, routes or
// frames it is not entitled to. Driven over loopback by hand (SecuredRawPeer)
// and through a tap that sees and changes the bytes on the wire (TcpTap).
// Each target keeps serving an honest subscriber while the attacks run.
#include <unistd.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <chrono>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "net/wire.h"
#include "peis/error.h"
#include "peis/peis.h"
#include "raw_peer.h"
#include "secured_peer.h"
#include "support/error_matchers.h"
#include "support/process.h"
#include "support/temp_dir.h"
#include "support/wait_for.h"

namespace {

using namespace std::chrono_literals;
using peis::PeisId;
using peis::test::SecuredRawPeer;
using peis::test::TestRoot;
using peis::test::waitFor;
namespace wire = peis::wire;

std::string ecologyName(const std::string& what) {
  return "secured-" + what + "-" + std::to_string(getpid());
}

peis::Options options(const std::string& credentials, PeisId id,
                      std::vector<std::string> connect = {}) {
  peis::Options o;
  o.id = id;
  o.credentials = credentials;
  o.discovery = false;
  o.connect = std::move(connect);
  o.liveness = 30s;  // raw peers answer no pings
  return o;
}

std::string at(const peis::Kernel& k) { return "127.0.0.1:" + std::to_string(k.port()); }

const peis::PeerInfo* peerOf(const std::vector<peis::PeerInfo>& peers, PeisId id) {
  for (const auto& p : peers) {
    if (p.id == id) return &p;
  }
  return nullptr;
}

bool hasPeer(const peis::Kernel& k, PeisId id) {
  const auto peers = k.peers();
  return peerOf(peers, id) != nullptr;
}

// Owner A and subscriber B of one secured ecology, linked; B follows A's
// counter.
struct Secured {
  explicit Secured(const std::string& what, peis::Limits limits = {})
      : ecology(ecologyName(what)), root(ecology) {
    root.issue("a");
    root.issue("b");
    root.issue("mallory");
    auto o = options(root.dir() + "/a.cred", 9001);
    o.limits = limits;
    owner = std::make_unique<peis::Kernel>(o);
    subscriber =
        std::make_unique<peis::Kernel>(options(root.dir() + "/b.cred", 9002, {at(*owner)}));
    subscriber->subscribe(peis::Pattern::exact(9001, "counter"));
    REQUIRE(stillServing());
  }
  bool stillServing() {
    const auto value = std::to_string(++round);
    owner->set("counter", value);
    return waitFor([&] {
      auto t = subscriber->get(9001, "counter");
      return t && t->data == value;
    });
  }
  wire::Hello helloAs(PeisId id, const std::string& name, std::uint64_t incarnation = 1ull << 62) {
    wire::Hello h;
    h.ecology = ecology;
    h.id = id;
    h.incarnation = incarnation;
    h.name = name;
    return h;
  }

  std::string ecology;
  TestRoot root;
  std::unique_ptr<peis::Kernel> owner, subscriber;
  int round = 0;
};

// A and B of one secured ecology, linked, B dialling A through a tap that
// records the bytes on the wire.
struct Tapped {
  explicit Tapped(const std::string& what) : ecology(ecologyName(what)), root(ecology) {
    root.issue("a");
    root.issue("b");
    a = std::make_unique<peis::Kernel>(options(root.dir() + "/a.cred", 9001));
    tap = std::make_unique<peis::test::TcpTap>(a->port());
    b = std::make_unique<peis::Kernel>(
        options(root.dir() + "/b.cred", 9002, {"127.0.0.1:" + std::to_string(tap->port())}));
    REQUIRE(waitFor([&] { return hasPeer(*a, 9002) && hasPeer(*b, 9001); }));
  }
  std::string ecology;
  TestRoot root;
  std::unique_ptr<peis::Kernel> a;
  std::unique_ptr<peis::test::TcpTap> tap;
  std::unique_ptr<peis::Kernel> b;
};

}  // namespace

TEST_CASE("secured ecology: members link and exchange tuples that the wire does not show",
          "[integration]") {
  Tapped e("wire");
  auto& a = *e.a;
  auto& b = *e.b;
  auto& tap = *e.tap;
  CHECK(a.options().ecology == e.ecology);  // taken from the credentials
  CHECK(peerOf(a.peers(), 9002)->name == "b");

  const std::string secret = "the-secret-value-" + std::to_string(getpid());
  const std::string reply = "the-secret-reply-" + std::to_string(getpid());
  b.subscribe(peis::Pattern::exact(9001, "vault.code"));
  a.set("vault.code", secret);
  REQUIRE(waitFor([&] {
    auto t = b.get(9001, "vault.code");
    return t && t->data == secret;
  }));
  b.set(9001, "vault.reply", reply);
  CHECK(a.get("vault.reply")->data == reply);
  // What passed on the wire: the Hellos in clear, then records only.
  const auto wire = tap.seen();
  CHECK(wire.size() > 200);
  CHECK(wire.find(secret) == std::string::npos);
  CHECK(wire.find(reply) == std::string::npos);
  CHECK(wire.find("vault") == std::string::npos);
  CHECK(wire.find("kernel.name") == std::string::npos);
}

namespace {

// A value of `size` bytes that starts with `marker` (what a tap looks for).
std::string valueOf(const std::string& marker, std::size_t size) {
  std::string v = marker;
  v.resize(std::max(size, marker.size()), 'q');
  return v;
}

// A (dialled through `tap`) and B in `ecology` (secured when `credentials`
// is set): values of several sizes, a big tuple's among them (its data is
// sent from the stored tuple), set by A one at a time and followed by B,
// and remote writes of B to A (sent by B's kernel thread). Each of A's is
// the only send of its thread at the time, so it goes out as a direct send
// from the writing thread once the kernel thread has served the
// destination. Returns the markers sent.
std::vector<std::string> exchangeOneAtATime(peis::Kernel& a, peis::Kernel& b, const char* what) {
  std::vector<std::string> markers;
  b.subscribe(peis::Pattern("direct.*", 9001));
  const std::size_t sizes[] = {24, 1024, 20 * 1024};
  for (int i = 0; i < 30; ++i) {
    const auto marker =
        std::string(what) + "-from-a-" + std::to_string(getpid()) + "-" + std::to_string(i) + "-";
    markers.push_back(marker);
    const auto value = valueOf(marker, sizes[i % 3]);
    a.set("direct.value", value);
    REQUIRE(waitFor([&] {
      auto t = b.get(9001, "direct.value");
      return t && t->data == value;
    }));
    if (i % 5 == 4) {
      const auto back =
          std::string(what) + "-from-b-" + std::to_string(getpid()) + "-" + std::to_string(i) + "-";
      markers.push_back(back);
      b.set(9001, "direct.back", valueOf(back, sizes[i % 3]));
      REQUIRE(a.get("direct.back")->data == valueOf(back, sizes[i % 3]));
    }
  }
  return markers;
}

}  // namespace

// Direct sends (docs/architecture.md): the writing thread writes to the
// link itself, not the kernel thread. On a secured link they are sealed
// like everything else. The open ecology beside it shows that the tap does
// see what direct sends write (the same markers, in clear).
TEST_CASE("secured ecology: direct sends from the writing thread are sealed too", "[integration]") {
  SECTION("open ecology: the tap sees the values in clear") {
    peis::Options o;
    o.ecology = ecologyName("direct-open");
    o.discovery = false;
    o.id = 9001;
    peis::Kernel a(o);
    peis::test::TcpTap tap(a.port());
    o.id = 9002;
    o.connect = {"127.0.0.1:" + std::to_string(tap.port())};
    peis::Kernel b(o);
    REQUIRE(waitFor([&] { return hasPeer(a, 9002) && hasPeer(b, 9001); }));
    const auto markers = exchangeOneAtATime(a, b, "open");
    CHECK(a.networkStats().directFramesOut > 0);
    const auto wire = tap.seen();
    std::size_t inClear = 0;
    for (const auto& m : markers) inClear += wire.find(m) != std::string::npos ? 1 : 0;
    CHECK(inClear == markers.size());
  }
  SECTION("secured ecology: nothing in clear, the same sends direct") {
    Tapped e("direct");
    auto& a = *e.a;
    auto& b = *e.b;
    auto& tap = *e.tap;
    const auto markers = exchangeOneAtATime(a, b, "secured");
    CHECK(a.networkStats().directFramesOut > 0);
    const auto wire = tap.seen();
    CHECK(wire.size() > 30 * 1024);
    for (const auto& m : markers) CHECK(wire.find(m) == std::string::npos);
    CHECK(wire.find(std::string(64, 'q')) == std::string::npos);
    CHECK(wire.find("direct.value") == std::string::npos);
    CHECK(a.networkStats().malformedFrames == 0);
    CHECK(b.networkStats().malformedFrames == 0);
  }
}

// The record layer with sends from several threads at once: application
// threads sending direct, the kernel thread flushing batches (streams,
// big tuples, pings), remote writes both ways. A record sealed out of the
// order it goes out fails its integrity check at the peer, which closes
// the link: the link must stay up and every last value arrive.
TEST_CASE("secured ecology: records stay in order with sends from many threads", "[integration]") {
  const auto ecology = ecologyName("threads");
  TestRoot root(ecology);
  root.issue("a");
  root.issue("b");
  peis::Kernel a(options(root.dir() + "/a.cred", 9001));
  peis::Kernel b(options(root.dir() + "/b.cred", 9002, {at(a)}));
  REQUIRE(waitFor([&] { return hasPeer(a, 9002) && hasPeer(b, 9001); }));
  b.subscribe(peis::Pattern("stress.*", 9001));
  a.subscribe(peis::Pattern("echo.*", 9002));
  constexpr int kWriters = 3, kValues = 400;
  std::vector<std::thread> threads;
  for (int w = 0; w < kWriters; ++w) {
    threads.emplace_back([&a, w] {
      for (int i = 0; i < kValues; ++i) {
        const std::size_t size = i % 50 == 0 ? 20 * 1024 : (i % 7 == 0 ? 2048 : 16);
        a.set("stress." + std::to_string(w), valueOf(std::to_string(i) + "/", size));
        if (i % 16 == 0) std::this_thread::yield();
      }
      a.set("stress." + std::to_string(w), "done");
    });
  }
  threads.emplace_back([&b] {
    for (int i = 0; i < kValues / 4; ++i) {
      b.set("echo.n", std::to_string(i));
      if (i % 10 == 0) b.set(9001, "stress.remote", std::to_string(i));
    }
    b.set("echo.n", "done");
  });
  for (auto& t : threads) t.join();
  CHECK(waitFor([&] {
    for (int w = 0; w < kWriters; ++w) {
      auto t = b.get(9001, "stress." + std::to_string(w));
      if (!t || t->data != "done") return false;
    }
    auto e = a.get(9002, "echo.n");
    return e && e->data == "done";
  }));
  CHECK(a.get("stress.remote")->data == std::to_string((kValues / 4 - 1) / 10 * 10));
  // One link all along: no record failed its check, nothing was cut off.
  CHECK(a.networkStats().garbagePeersDisconnected == 0);
  CHECK(b.networkStats().garbagePeersDisconnected == 0);
  CHECK(a.networkStats().malformedFrames == 0);
  CHECK(b.networkStats().malformedFrames == 0);
  CHECK(a.networkStats().directFramesOut + b.networkStats().directFramesOut > 0);
  CHECK(hasPeer(a, 9002));
}

// A direct send that finds the socket's buffer all but full (a reader that
// is slow: its receive buffer is tiny) writes part of its records; the rest
// goes out first, before what is sealed after it. The reader then opens
// every record in order (a record out of order fails its check) up to the
// last value.
TEST_CASE("secured ecology: a direct send the socket takes only part of goes on in order",
          "[integration]") {
  Secured e("partial");
  const auto mallory = e.root.load("mallory");
  SecuredRawPeer slow(e.owner->port(), mallory, e.helloAs(9100, "mallory"), 4096);
  REQUIRE(slow.exchangeHellos());
  slow.sendAuth();
  REQUIRE(slow.awaitAuth());
  REQUIRE(slow.send(
      peis::test::frameOf(wire::RoutedMessage{wire::Envelope{9100, 9001, wire::kDefaultTtl},
                                              wire::Subscribe{1, 600000, PeisId{9001}, "big"}})));
  REQUIRE(waitFor([&] { return hasPeer(*e.owner, 9100); }));
  const auto direct0 = e.owner->networkStats().directFramesOut;
  // Values of 20 KiB one at a time (a pause between them, so each is a
  // direct send rather than part of a stream), far more than the socket
  // buffers hold, until the link's backlog stops direct sends.
  for (int i = 0; i < 400; ++i) {
    e.owner->set("big", valueOf("big-" + std::to_string(i) + "-", 20 * 1024));
    std::this_thread::sleep_for(200us);  // the pacing under test: each value a direct send
  }
  const auto last = valueOf("big-last-", 20 * 1024);
  e.owner->set("big", last);
  CHECK(e.owner->networkStats().directFramesOut > direct0);
  // Every record opens, in order, up to the last value.
  bool seenLast = false;
  while (!seenLast) {
    auto frame = slow.readFrame(20s);
    REQUIRE(frame);
    seenLast = frame->find(last) != std::string::npos;
  }
  CHECK(e.owner->networkStats().garbagePeersDisconnected == 0);
  CHECK(e.stillServing());
}

TEST_CASE("secured ecology: relayed frames prove their source, end to end", "[integration]") {
  const auto ecology = ecologyName("relay");
  TestRoot root(ecology);
  for (const auto* name : {"a", "b", "c"}) root.issue(name);
  peis::Kernel a(options(root.dir() + "/a.cred", 9001));
  peis::Kernel b(options(root.dir() + "/b.cred", 9002, {at(a)}));
  peis::Kernel c(options(root.dir() + "/c.cred", 9003, {at(b)}));
  REQUIRE(waitFor([&] { return hasPeer(c, 9001) && hasPeer(a, 9003); }));
  CHECK(peerOf(c.peers(), 9001)->hops == 2);
  c.subscribe(peis::Pattern::exact(9001, "far"));
  a.set("far", "over b");
  CHECK(waitFor([&] {
    auto t = c.get(9001, "far");
    return t && t->data == "over b";
  }));
  c.set(9001, "back", "from c");
  CHECK(a.get("back")->creator == 9003);
  CHECK(a.networkStats().unentitled == 0);
  CHECK(c.networkStats().unentitled == 0);
}

TEST_CASE("secured ecology: a PEIS without credentials or of another root is refused", "[fault]") {
  Secured e("refused");
  // An open PEIS of the same ecology name.
  peis::Options open;
  open.ecology = e.ecology;
  open.discovery = false;
  open.connect.push_back(at(*e.owner));
  peis::Kernel outsider(open);
  CHECK(waitFor([&] { return e.owner->networkStats().authRefused >= 1; }));
  CHECK(waitFor([&] { return outsider.networkStats().authRefused >= 1; }));
  // Credentials of another trust root that calls its ecology the same.
  TestRoot other(e.ecology);
  other.issue("a");
  peis::Kernel impostor(options(other.dir() + "/a.cred", 9005, {at(*e.owner)}));
  const auto refused = e.owner->networkStats().authRefused;
  CHECK(waitFor([&] { return e.owner->networkStats().authRefused > refused; }));
  CHECK_FALSE(hasPeer(*e.owner, 9005));
  CHECK_FALSE(hasPeer(outsider, 9001));
  // A raw open Hello.
  {
    peis::test::RawPeer raw(e.owner->port());
    raw.send(peis::test::helloFrame(e.ecology, 9006));
    CHECK(raw.closedByPeer());
  }
  CHECK(e.stillServing());
}

TEST_CASE("secured ecology: forged and replayed handshakes are refused", "[fault]") {
  Secured e("replay");
  const auto port = e.owner->port();
  const auto b = e.root.load("b");
  const auto mallory = e.root.load("mallory");
  const auto incarnationOfB = std::stoull(e.subscriber->get(peis::special::kStarted)->data);

  SECTION("an identity that is not the one its Hello claims") {
    SecuredRawPeer peer(port, mallory, e.helloAs(9002, "b", incarnationOfB));
    REQUIRE(peer.exchangeHellos());
    peer.sendAuth(peis::security::encodeIdentity(
                      peis::security::makeIdentity(mallory, 9100, 1ull << 62, "mallory")),
                  std::string(64, 'x'));
    CHECK(peer.closedByPeer());
  }
  SECTION("a name its credentials do not allow") {
    SecuredRawPeer peer(port, mallory, e.helloAs(9100, "a"));
    REQUIRE(peer.exchangeHellos());
    peer.sendAuth();
    CHECK(peer.closedByPeer());
  }
  SECTION("an Auth recorded on another link") {
    // A session of B's key, whose Auth an eavesdropper of B's side saw...
    auto hello = e.helloAs(9102, "b");
    std::string signature;
    {
      SecuredRawPeer first(port, b, hello);
      REQUIRE(first.exchangeHellos());
      first.sendAuth();
      REQUIRE(first.awaitAuth());
      signature = first.handshake().transcriptSignature();
    }
    // ... replayed over a fresh key exchange: the transcript differs.
    const auto identity = peis::security::makeIdentity(b, hello.id, hello.incarnation, hello.name);
    SecuredRawPeer replay(port, mallory, hello);
    REQUIRE(replay.exchangeHellos());
    const auto refused = e.owner->networkStats().authRefused;
    replay.sendAuth(peis::security::encodeIdentity(identity), signature);
    CHECK(replay.closedByPeer());
    CHECK(e.owner->networkStats().authRefused > refused);
  }
  SECTION("a whole recorded handshake, byte for byte") {
    peis::test::TcpTap tap(port);
    {
      SecuredRawPeer first(tap.port(), b, e.helloAs(9103, "b"));
      REQUIRE(first.exchangeHellos());
      first.sendAuth();
      REQUIRE(first.awaitAuth());
      // The owner took our Auth: the tap holds the whole handshake (both
      // sides send their Auth at once, so ours may still be on its way).
      REQUIRE(waitFor([&] { return hasPeer(*e.owner, 9103); }));
    }
    const auto garbage = e.owner->networkStats().garbagePeersDisconnected;
    peis::test::RawPeer replay(port);
    replay.send(tap.sentToTarget());
    CHECK(replay.closedByPeer());
    // Its records fail under the new link's keys.
    CHECK(e.owner->networkStats().garbagePeersDisconnected > garbage);
  }
  CHECK(e.owner->networkStats().authRefused + e.owner->networkStats().garbagePeersDisconnected >=
        1);
  CHECK(e.stillServing());
}

TEST_CASE("secured ecology: an authenticated peer cannot announce what it is not entitled to",
          "[fault]") {
  Secured e("entitled");
  const auto mallory = e.root.load("mallory");
  // C hangs off B only: A reaches it in 2 hops through B.
  e.root.issue("c");
  peis::Kernel c(options(e.root.dir() + "/c.cred", 9003, {at(*e.subscriber)}));
  REQUIRE(waitFor([&] { return hasPeer(*e.owner, 9003); }));
  const auto incarnationOfC = std::stoull(c.get(peis::special::kStarted)->data);

  SecuredRawPeer peer(e.owner->port(), mallory, e.helloAs(9100, "mallory"));
  REQUIRE(peer.exchangeHellos());
  peer.sendAuth();
  REQUIRE(peer.awaitAuth());
  REQUIRE(waitFor([&] { return hasPeer(*e.owner, 9100); }));
  const auto before = e.owner->networkStats();
  // Routes to a PEIS that does not exist, to B under another name, to C in
  // one hop (as short as B's route: frames from C may come this way).
  wire::Routes routes;
  routes.entries = {{9100, 0, 0, 1ull << 62, 0, "mallory"},
                    {424242, 1, 0, 5, 1, "ghost"},
                    {9002, 1, 0, 1, 1, "evil"},
                    {9003, 1, 0, incarnationOfC, 1000, "c"}};
  peer.send(peis::test::frameOf(wire::LinkMessage{routes}));
  // An identity the trust root never signed.
  auto forged = peis::security::makeIdentity(mallory, 424243, 1, "ghost2");
  forged.certificate.principal = "admin";
  peer.send(peis::test::frameOf(
      wire::LinkMessage{wire::Identity{peis::security::encodeIdentity(forged)}}));
  // A frame "from C" (2 hops away) without, and then with a made-up, tag.
  wire::TupleUpdate update;
  update.ownerIncarnation = incarnationOfC;
  update.tuple.owner = 9003;
  update.tuple.creator = 9003;
  update.tuple.key = "forged";
  update.tuple.data = "x";
  update.tuple.seqno = 1ull << 63;
  const auto fromC =
      peis::test::frameOf(wire::RoutedMessage{wire::Envelope{9003, 9001, 5}, update});
  peer.send(fromC);
  peer.send(peis::test::frameOf(wire::LinkMessage{wire::SourceTag{std::string(16, 't')}}));
  peer.send(fromC);
  REQUIRE(peer.sync());
  CHECK_FALSE(hasPeer(*e.owner, 424242));
  CHECK_FALSE(hasPeer(*e.owner, 424243));
  CHECK(peerOf(e.owner->peers(), 9002)->name == "b");
  CHECK_FALSE(e.owner->get(9003, "forged"));
  const auto after = e.owner->networkStats();
  CHECK(after.unentitled >= before.unentitled + 4);
  CHECK(e.stillServing());
  // C's own frames still come through B, proven.
  c.set(9001, "real", "from c");
  CHECK(e.owner->get("real")->creator == 9003);
}

TEST_CASE("secured ecology: an id its credentials pin is never given up", "[fault]") {
  const auto ecology = ecologyName("pinned");
  TestRoot root(ecology);
  root.issue("lamp", {"devices"}, {}, 5000);
  root.issue("mallory");
  auto o = options(root.dir() + "/lamp.cred", 0);
  o.id.reset();
  peis::Kernel lamp(o);
  CHECK(lamp.id() == 5000);
  // Another --peis-id with those credentials is an error.
  auto wrong = options(root.dir() + "/lamp.cred", 17);
  CHECK_THROWS_WITH(peis::Kernel(wrong), Catch::Contains("pin id 5000"));
  // An authenticated peer claiming 5000 and an earlier start.
  const auto mallory = root.load("mallory");
  wire::Hello hello;
  hello.ecology = ecology;
  hello.id = 5000;
  hello.incarnation = 1;
  hello.name = "mallory";
  SecuredRawPeer peer(lamp.port(), mallory, hello);
  REQUIRE(peer.exchangeHellos());
  peer.sendAuth();
  CHECK(peer.closedByPeer());
  CHECK(lamp.id() == 5000);
}

TEST_CASE("secured ecology: the malformed-frame corpus and the limits hold on secured links",
          "[fault]") {
  peis::Limits limits;
  limits.handshake = 500ms;
  Secured e("corpus", limits);
  const auto mallory = e.root.load("mallory");

  SECTION("bad frames inside good records: dropped, counted, then cut off") {
    SecuredRawPeer peer(e.owner->port(), mallory, e.helloAs(9100, "mallory"));
    REQUIRE(peer.exchangeHellos());
    peer.sendAuth();
    REQUIRE(peer.awaitAuth());
    const auto stats0 = e.owner->networkStats();
    auto raw = [](std::uint8_t type, const std::string& body) {
      std::string out;
      const auto length = static_cast<std::uint32_t>(body.size() + 1);
      for (int i = 3; i >= 0; --i) out.push_back(static_cast<char>(length >> (8 * i)));
      out.push_back(static_cast<char>(type));
      return out + body;
    };
    const std::vector<std::string> bad = {
        raw(99, "x"),
        raw(2, "short"),
        raw(2, std::string(9, 'x')),
        peis::test::frameOf(wire::RoutedMessage{wire::Envelope{9100, 9001, 5},
                                                wire::Subscribe{1, 1000, std::nullopt, "a..b"}}),
        peis::test::frameOf(
            wire::RoutedMessage{wire::Envelope{9002, 9001, 5}, wire::Unsubscribe{1}}),
        raw(18, std::string(40, '\xff')),
        raw(8, "an Auth out of place"),
        raw(1, "again"),
    };
    for (const auto& f : bad) peer.send(f);
    CHECK(peer.closedByPeer());
    CHECK(e.owner->networkStats().malformedFrames >= stats0.malformedFrames + 7);
  }
  SECTION("a record changed on the way closes the link") {
    SecuredRawPeer peer(e.owner->port(), mallory, e.helloAs(9100, "mallory"));
    REQUIRE(peer.exchangeHellos());
    peer.sendAuth();
    REQUIRE(peer.awaitAuth());
    REQUIRE(peer.sync());
    auto record = peer.seal(peis::test::frameOf(wire::LinkMessage{wire::Ping{2}}));
    record[record.size() / 2] ^= 0x01;
    const auto garbage = e.owner->networkStats().garbagePeersDisconnected;
    peer.sendRaw(record);
    CHECK(peer.closedByPeer());
    CHECK(e.owner->networkStats().garbagePeersDisconnected > garbage);
  }
  SECTION("a Hello without its Auth is closed at the handshake deadline") {
    SecuredRawPeer peer(e.owner->port(), mallory, e.helloAs(9101, "mallory"));
    REQUIRE(peer.exchangeHellos());
    CHECK(peer.closedByPeer());
    CHECK(e.owner->networkStats().handshakeTimeouts >= 1);
  }
  CHECK(e.stillServing());
}

// The three commands of docs/security.md and the README, with the `peis`
// tool and `peis node` processes: from nothing to a secured ecology whose
// PEIS find and use each other, while a PEIS without the credentials sees
// and reaches none of them.
TEST_CASE("secured ecology: three commands from nothing", "[integration]") {
  peis::test::TempDir dir("peis_three");
  const auto keys = dir.file("peis-keys");
  const auto ecology = ecologyName("three");
  auto run = [&](std::vector<std::string> args, peis::test::Process::Environment env = {}) {
    args.insert(args.begin(), peis::test::peisCliPath());
    peis::test::Process p(args, env);
    const auto status = p.wait(30s);
    INFO(p.describe());
    REQUIRE(status.has_value());
    return std::make_pair(*status, p.out() + p.err());
  };
  auto init = run({"keys", "init", ecology, "--dir", keys});
  REQUIRE(init.first == 0);
  CHECK(init.second.find("trust root of the secured ecology '" + ecology + "'") !=
        std::string::npos);
  auto add = run({"keys", "add", "home", "--names", "*", "--group", "admin", "--dir", keys});
  REQUIRE(add.first == 0);
  CHECK(add.second.find("groups     admin") != std::string::npos);
  // Mistakes are clear errors.
  CHECK(run({"keys", "init", ecology, "--dir", keys}).first != 0);  // a root exists
  CHECK(run({"keys", "add", "a.b", "--dir", keys}).first == 2);     // not a name
  CHECK(run({"keys", "show", dir.write("junk.cred", "x: [")}).first != 0);

  const peis::test::Process::Environment secured{{"PEIS_CREDENTIALS", keys + "/home.cred"}};
  auto nodeEnv = secured;
  nodeEnv.emplace_back("PEIS_LOG", "info");
  peis::test::Process a({peis::test::peisCliPath(), "node", "--peis-name", "a"}, nodeEnv);
  peis::test::Process b({peis::test::peisCliPath(), "node", "--peis-name", "b"}, nodeEnv);
  CHECK(waitFor([&] {
    return run({"set", "a.greeting", "hello", "--timeout", "5"}, secured).first == 0;
  }));
  auto got = run({"get", "a.greeting", "--wait", "10"}, secured);
  CHECK(got.second == "hello\n");
  auto ls = run({"ls"}, secured);
  CHECK(ls.second.find(" a ") != std::string::npos);
  CHECK(ls.second.find(" b ") != std::string::npos);
  // Without the credentials: nothing to see or reach in that ecology.
  auto outsider = run({"get", "a.greeting", "--wait", "3", "--peis-ecology", ecology});
  CHECK(outsider.first != 0);
  // The home credentials are an administrator's: they stop the PEIS.
  const auto quit = run({"set", "a.kernel.do-quit", "yes"}, secured);
  INFO(quit.second);
  CHECK(quit.first == 0);
  CHECK(a.wait(20s).has_value());
}
