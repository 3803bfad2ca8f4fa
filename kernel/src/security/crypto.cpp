// The libsodium operations the security layer uses; see crypto.h.
#include "security/crypto.h"

#include <sodium.h>

#include <stdexcept>

namespace peis::security {

namespace {
const unsigned char* bytes(std::string_view s) {
  return reinterpret_cast<const unsigned char*>(s.data());
}
unsigned char* bytes(std::string& s) { return reinterpret_cast<unsigned char*>(s.data()); }
}  // namespace

void initCrypto() {
  // sodium_init is thread-safe and returns 1 once it ran before.
  if (sodium_init() < 0) throw std::runtime_error("libsodium cannot be initialised");
}

SignKeyPair newSignKeyPair() {
  initCrypto();
  SignKeyPair pair{std::string(crypto_sign_PUBLICKEYBYTES, '\0'),
                   std::string(crypto_sign_SECRETKEYBYTES, '\0')};
  crypto_sign_keypair(bytes(pair.publicKey), bytes(pair.secretKey));
  return pair;
}

std::string sign(std::string_view message, std::string_view secretKey) {
  std::string signature(crypto_sign_BYTES, '\0');
  if (secretKey.size() != crypto_sign_SECRETKEYBYTES) return {};
  crypto_sign_detached(bytes(signature), nullptr, bytes(message), message.size(), bytes(secretKey));
  return signature;
}

bool verify(std::string_view signature, std::string_view message, std::string_view publicKey) {
  if (signature.size() != crypto_sign_BYTES || publicKey.size() != crypto_sign_PUBLICKEYBYTES) {
    return false;
  }
  return crypto_sign_verify_detached(bytes(signature), bytes(message), message.size(),
                                     bytes(publicKey)) == 0;
}

bool keysMatch(std::string_view publicKey, std::string_view secretKey) {
  if (publicKey.size() != crypto_sign_PUBLICKEYBYTES ||
      secretKey.size() != crypto_sign_SECRETKEYBYTES) {
    return false;
  }
  std::string derived(crypto_sign_PUBLICKEYBYTES, '\0');
  crypto_sign_ed25519_sk_to_pk(bytes(derived), bytes(secretKey));
  return sameBytes(derived, publicKey);
}

std::string hash(std::string_view message) {
  std::string out(crypto_generichash_BYTES, '\0');
  crypto_generichash(bytes(out), out.size(), bytes(message), message.size(), nullptr, 0);
  return out;
}

std::string keyedHash(std::string_view key, std::string_view message, std::size_t outBytes) {
  std::string out(outBytes, '\0');
  crypto_generichash(bytes(out), out.size(), bytes(message), message.size(), bytes(key),
                     key.size());
  return out;
}

std::string fingerprint(std::string_view publicKey) { return toHex(hash(publicKey).substr(0, 8)); }

std::string randomBytes(std::size_t n) {
  initCrypto();
  std::string out(n, '\0');
  randombytes_buf(out.data(), n);
  return out;
}

std::uint64_t randomU64() {
  const auto b = randomBytes(8);
  std::uint64_t v = 0;
  for (char c : b) v = (v << 8) | static_cast<std::uint8_t>(c);
  return v;
}

bool sameBytes(std::string_view a, std::string_view b) {
  return a.size() == b.size() && sodium_memcmp(a.data(), b.data(), a.size()) == 0;
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
