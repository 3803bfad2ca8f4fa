// libFuzzer target for the wire decoder (built and run by run_fuzz.sh).
// Any input must decode or be rejected with a reason, never crash or read
// out of bounds (ASan/UBSan watch that). What decodes must survive a round
// trip: encoding it and decoding the bytes again gives an equal message,
// and encoding that gives the same bytes again (the encoding is canonical).
// The same bytes read as an oversized frame's head never crash either. The
// receive path's decoder and a stream's encoder agree with decode() and
// encode().
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>
#include <variant>

#include "net/wire.h"

namespace {

constexpr std::size_t kMaxDataBytes = 64 * 1024;

[[noreturn]] void fail(const char* what, const std::string& detail = {}) {
  std::fprintf(stderr, "wire_fuzz: %s %s\n", what, detail.c_str());
  std::abort();
}

std::string encodeMessage(const peis::wire::Message& message) {
  std::string out;
  if (const auto* link = std::get_if<peis::wire::LinkMessage>(&message)) {
    peis::wire::encode(*link, out);
  } else {
    peis::wire::encode(std::get<peis::wire::RoutedMessage>(message), out);
  }
  return out;
}

peis::wire::Message decodeFrame(const std::string& frame) {
  if (frame.size() < peis::wire::kFrameHeaderBytes) fail("frame shorter than its header");
  if (peis::wire::frameLength(frame) != frame.size() - peis::wire::kFrameHeaderBytes) {
    fail("length prefix does not match the frame");
  }
  auto result = peis::wire::decode(std::string_view(frame).substr(peis::wire::kFrameHeaderBytes),
                                   kMaxDataBytes);
  if (!result.message) fail("re-encoded message does not decode:", result.error);
  return std::move(*result.message);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  // Read as the head of a frame over a small limit: what passes is answered
  // with a frame that decodes.
  if (const auto oversize = peis::wire::decodeOversize(input, 16)) {
    if (oversize->dataBytes <= 16) fail("an oversized frame within the limit");
    decodeFrame(peis::wire::encodeFrame(peis::wire::answerOversize(*oversize, 5, 16)));
  }
  auto result = peis::wire::decode(input, kMaxDataBytes);
  // The receive path's decoder (decodeRouted, with its fast path for tuple
  // updates) agrees with decode() on every routed frame: the same verdict
  // and the same message. It decodes into a message that the inputs before
  // left behind, as the network's inbox reuses its messages.
  if (peis::wire::isRoutedFrame(input)) {
    static peis::wire::RoutedMessage reused;
    std::string error;
    const bool ok = peis::wire::decodeRouted(input, kMaxDataBytes, reused, error);
    if (ok != result.message.has_value()) fail("decodeRouted and decode disagree:", error);
    if (!ok && error.empty()) fail("decodeRouted rejected without a reason");
    if (ok && !(peis::wire::Message{reused} == *result.message)) {
      fail("decodeRouted decoded another message than decode");
    }
  }
  if (!result.message) {
    if (result.error.empty()) fail("rejected without a reason");
    return 0;
  }
  if (!result.error.empty()) fail("decoded with an error:", result.error);

  const auto& message = *result.message;
  const auto first = encodeMessage(message);
  const auto again = decodeFrame(first);
  if (!(again == message)) fail("round trip changed the message");
  if (encodeMessage(again) != first) fail("encoding is not stable");

  if (const auto* routed = std::get_if<peis::wire::RoutedMessage>(&message)) {
    if (const auto* update = std::get_if<peis::wire::TupleUpdate>(&routed->body)) {
      std::string direct;
      peis::wire::encodeTupleUpdate(routed->envelope, update->ownerIncarnation, update->tuple,
                                    direct);
      if (direct != first) fail("encodeTupleUpdate differs from encode");
      // A stream's encoder (its repeated fields kept from the inputs before)
      // writes the same bytes.
      static peis::wire::TupleUpdateEncoder encoder;
      std::string streamed;
      encoder.append(routed->envelope, update->ownerIncarnation, update->tuple, streamed);
      if (streamed != first) fail("TupleUpdateEncoder differs from encode");
    }
    // Re-enveloping (as a forwarding PEIS does) keeps the body.
    auto forwarded = first;
    auto envelope = routed->envelope;
    envelope.ttl = static_cast<std::uint8_t>(envelope.ttl - 1);
    peis::wire::reEnvelope(forwarded, envelope);
    auto expected = *routed;
    expected.envelope = envelope;
    if (!(decodeFrame(forwarded) == peis::wire::Message{expected}))
      fail("reEnvelope broke a frame");
  }
  return 0;
}
