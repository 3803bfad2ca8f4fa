// The secured link handshake's cryptography; see link_handshake.h.
#include "security/link_handshake.h"

#include "security/backend.h"
#include "security/bytes.h"
#include "security/crypto.h"

namespace peis::security {

namespace {

constexpr std::uint8_t kSuiteAes = 1;
constexpr std::uint8_t kSuiteChaCha = 2;
constexpr std::size_t kRootIdBytes = 16;
constexpr std::string_view kKeysContext = "PEIS v3 record keys";
constexpr std::string_view kTranscriptContext = "PEIS v3 link";

const unsigned char* u(std::string_view s) {
  return reinterpret_cast<const unsigned char*>(s.data());
}
unsigned char* u(std::string& s) { return reinterpret_cast<unsigned char*>(s.data()); }

}  // namespace

std::string rootIdOf(std::string_view rootKey) { return hash(rootKey).substr(0, kRootIdBytes); }

std::string encodeHelloAuth(const HelloAuth& a) {
  ByteWriter w;
  w.u8(1);  // scheme
  w.u8(a.suites);
  w.raw(a.ephemeralKey);
  w.raw(a.rootId);
  return w.take();
}

std::optional<HelloAuth> decodeHelloAuth(std::string_view bytes, std::string& error) {
  ByteReader r(bytes);
  HelloAuth a;
  const auto scheme = r.u8();
  a.suites = static_cast<std::uint8_t>(r.u8());
  a.ephemeralKey = std::string(r.raw(kKxPublicKeyBytes));
  a.rootId = std::string(r.raw(kRootIdBytes));
  if (!r.ok() || !r.atEnd() || scheme != 1) {
    error = "its Hello's auth field is not a secured ecology's";
    return std::nullopt;
  }
  if ((a.suites & kSuiteChaCha) == 0) {
    error = "it runs no cipher suite this PEIS runs";
    return std::nullopt;
  }
  return a;
}

LinkHandshake::LinkHandshake(const Credentials& credentials, bool dialer)
    : credentials_(credentials),
      dialer_(dialer),
      ephemeralPublic_(kKxPublicKeyBytes, '\0'),
      ephemeralSecret_(kKxSecretKeyBytes, '\0') {
  backend().kxKeyPair(u(ephemeralPublic_), u(ephemeralSecret_));
}

LinkHandshake::~LinkHandshake() {
  wipe(ephemeralSecret_);
  wipe(sendKey_);
  wipe(receiveKey_);
}

std::string LinkHandshake::helloAuth() const {
  HelloAuth a;
  a.suites = kSuiteChaCha | (RecordCipher::aesAvailable() ? kSuiteAes : 0);
  a.ephemeralKey = ephemeralPublic_;
  a.rootId = rootIdOf(credentials_.rootKey);
  return encodeHelloAuth(a);
}

std::optional<std::string> LinkHandshake::onPeerHello(std::string_view peerAuth,
                                                      std::string_view ourHello,
                                                      std::string_view peerHello) {
  std::string error;
  const auto auth = decodeHelloAuth(peerAuth, error);
  if (!auth) return error;
  if (!sameBytes(auth->rootId, rootIdOf(credentials_.rootKey))) {
    return "it belongs to another secured ecology of this name (another trust root)";
  }
  const bool aes = (auth->suites & kSuiteAes) && RecordCipher::aesAvailable();
  suite_ = aes ? CipherSuite::Aes256Gcm : CipherSuite::ChaCha20Poly1305;
  transcript_ = hash(std::string(dialer_ ? ourHello : peerHello) +
                     std::string(dialer_ ? peerHello : ourHello));
  std::string rx(kKeyBytes, '\0'), tx(kKeyBytes, '\0');
  if (!backend().kxSessionKeys(dialer_, u(rx), u(tx), u(ephemeralPublic_), u(ephemeralSecret_),
                               u(auth->ephemeralKey))) {
    return "its ephemeral key is unusable";
  }
  const std::string context = std::string(kKeysContext) + transcript_;
  sendKey_ = keyedHash(tx, context, kKeyBytes);
  receiveKey_ = keyedHash(rx, context, kKeyBytes);
  wipe(rx);
  wipe(tx);
  return std::nullopt;
}

std::string LinkHandshake::signedTranscript(bool byDialer) const {
  return std::string(kTranscriptContext) + (byDialer ? "D" : "A") + transcript_;
}

std::string LinkHandshake::transcriptSignature() const {
  return sign(signedTranscript(dialer_), credentials_.secretKey);
}

std::variant<Identity, std::string> LinkHandshake::checkAuth(
    std::string_view identityBytes, std::string_view signature, PeisId helloId,
    std::uint64_t helloIncarnation, std::string_view helloName, const TrustAnchor& anchor,
    std::int64_t now) const {
  std::string error;
  auto in = identityBytes;
  auto identity = decodeIdentity(in, error);
  if (!identity || !in.empty()) return "its Auth is malformed: " + error;
  if (auto problem = identityProblem(*identity, anchor, now)) return *problem;
  if (identity->id != helloId || identity->incarnation != helloIncarnation ||
      identity->name != helloName) {
    return "its identity (PEIS " + std::to_string(identity->id) + " '" + identity->name +
           "') is not the one its Hello claims (PEIS " + std::to_string(helloId) + " '" +
           std::string(helloName) + "')";
  }
  if (!verify(signature, signedTranscript(!dialer_), identity->certificate.publicKey)) {
    return "its signature over this link's handshake does not hold (a replayed or forged "
           "handshake)";
  }
  return std::move(*identity);
}

}  // namespace peis::security
