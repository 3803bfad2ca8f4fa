// libFuzzer target for what a secured link parses before it trusts anything
// (built and run by run_fuzz.sh secured): a Hello's auth field, an
// identity (a certificate and a binding, also checked against a trust
// root), and records opened under fixed keys. Any bytes must be rejected
// with a reason, never crash or read out of bounds (ASan/UBSan watch); an
// identity that decodes must re-encode to the same bytes.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "security/identity.h"
#include "security/link_handshake.h"
#include "security/record_cipher.h"

namespace {

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "secured_fuzz: %s\n", what);
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  std::string error;
  (void)peis::security::decodeHelloAuth(input, error);

  std::string_view in = input;
  if (auto identity = peis::security::decodeIdentity(in, error)) {
    const auto consumed = input.substr(0, input.size() - in.size());
    if (peis::security::encodeIdentity(*identity) != consumed) fail("identity does not round-trip");
    const peis::security::TrustAnchor anchor{"fuzz", std::string(32, '\x01')};
    (void)peis::security::identityProblem(*identity, anchor, 1700000000);
  }

  static peis::security::RecordCipher chacha(peis::security::CipherSuite::ChaCha20Poly1305,
                                             std::string(32, 'k'), std::string(32, 'k'));
  std::string plain(input.size() + 1, '\0');
  std::size_t record = 0, bytes = 0;
  const auto verdict =
      chacha.open(input.data(), input.size(), peis::security::RecordCipher::kMaxPlainBytes,
                  plain.data(), record, bytes, error);
  if (verdict == peis::security::RecordCipher::Open::Opened &&
      (record > input.size() || bytes > record)) {
    fail("a record opened past its bytes");
  }
  return 0;
}
