// The cryptographic operations the security layer uses, each one call into
// the security module (libsodium's; backend.h); see crypto.h.
#include "security/crypto.h"

#include "security/backend.h"

namespace peis::security {

namespace {
const unsigned char* bytes(std::string_view s) {
  return reinterpret_cast<const unsigned char*>(s.data());
}
unsigned char* bytes(std::string& s) { return reinterpret_cast<unsigned char*>(s.data()); }
}  // namespace

void initCrypto() { backend(); }

SignKeyPair newSignKeyPair() {
  SignKeyPair pair{std::string(kSignPublicKeyBytes, '\0'), std::string(kSignSecretKeyBytes, '\0')};
  backend().signKeyPair(bytes(pair.publicKey), bytes(pair.secretKey));
  return pair;
}

std::string sign(std::string_view message, std::string_view secretKey) {
  if (secretKey.size() != kSignSecretKeyBytes) return {};
  std::string signature(kSignatureBytes, '\0');
  backend().sign(bytes(signature), bytes(message), message.size(), bytes(secretKey));
  return signature;
}

bool verify(std::string_view signature, std::string_view message, std::string_view publicKey) {
  if (signature.size() != kSignatureBytes || publicKey.size() != kSignPublicKeyBytes) {
    return false;
  }
  return backend().verify(bytes(signature), bytes(message), message.size(), bytes(publicKey));
}

bool keysMatch(std::string_view publicKey, std::string_view secretKey) {
  if (publicKey.size() != kSignPublicKeyBytes || secretKey.size() != kSignSecretKeyBytes) {
    return false;
  }
  std::string derived(kSignPublicKeyBytes, '\0');
  backend().secretToPublic(bytes(derived), bytes(secretKey));
  return sameBytes(derived, publicKey);
}

std::string hashParts(std::initializer_list<std::string_view> parts, std::size_t outBytes,
                      std::string_view key) {
  std::string out(outBytes, '\0');
  backend().hash(bytes(out), out.size(), parts.begin(), parts.size(), key);
  return out;
}

std::string hash(std::string_view message) { return hashParts({message}, kHashBytes); }

std::string keyedHash(std::string_view key, std::string_view message, std::size_t outBytes) {
  return hashParts({message}, outBytes, key);
}

std::string fingerprint(std::string_view publicKey) { return toHex(hash(publicKey).substr(0, 8)); }

std::string randomBytes(std::size_t n) {
  std::string out(n, '\0');
  backend().randomBytes(out.data(), n);
  return out;
}

std::uint64_t randomU64() {
  const auto b = randomBytes(8);
  std::uint64_t v = 0;
  for (char c : b) v = (v << 8) | static_cast<std::uint8_t>(c);
  return v;
}

bool sameBytes(std::string_view a, std::string_view b) {
  return a.size() == b.size() && backend().sameBytes(a.data(), b.data(), a.size());
}

void wipe(std::string& secret) {
  if (!secret.empty()) backend().wipe(secret.data(), secret.size());
}

std::string toHex(std::string_view in) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string out;
  out.reserve(2 * in.size());
  for (unsigned char c : in) {
    out.push_back(kDigits[c >> 4]);
    out.push_back(kDigits[c & 15]);
  }
  return out;
}

std::optional<std::string> fromHex(std::string_view hex) {
  if (hex.size() % 2 != 0) return std::nullopt;
  auto digit = [](char c) -> int {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
  };
  std::string out;
  out.reserve(hex.size() / 2);
  for (std::size_t i = 0; i < hex.size(); i += 2) {
    const int hi = digit(hex[i]), lo = digit(hex[i + 1]);
    if (hi < 0 || lo < 0) return std::nullopt;
    out.push_back(static_cast<char>(hi * 16 + lo));
  }
  return out;
}

}  // namespace peis::security
