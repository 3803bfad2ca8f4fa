// RecordCipher: AEAD records of a secured link; see record_cipher.h.
#include "security/record_cipher.h"

#include <openssl/core_names.h>
#include <openssl/evp.h>
#include <openssl/params.h>
#include <sodium.h>

#include <algorithm>
#include <cstring>
#include <stdexcept>

#include "security/crypto.h"

namespace peis::security {

struct RecordCipher::Keys {
  EVP_CIPHER_CTX* send = nullptr;
  EVP_CIPHER_CTX* receive = nullptr;
  ~Keys() {
    EVP_CIPHER_CTX_free(send);  // frees the expanded keys (cleansed)
    EVP_CIPHER_CTX_free(receive);
  }
};

namespace {

void nonceOf(std::uint64_t counter, unsigned char nonce[12]) {
  std::memset(nonce, 0, 4);
  for (int i = 0; i < 8; ++i) nonce[4 + i] = static_cast<unsigned char>(counter >> (56 - 8 * i));
}

const EVP_CIPHER* cipherOf(CipherSuite suite) {
  return suite == CipherSuite::Aes256Gcm ? EVP_aes_256_gcm() : EVP_chacha20_poly1305();
}

EVP_CIPHER_CTX* keyed(CipherSuite suite, std::string_view key, bool encrypt) {
  EVP_CIPHER_CTX* ctx = EVP_CIPHER_CTX_new();
  const auto* k = reinterpret_cast<const unsigned char*>(key.data());
  const int ok = ctx != nullptr &&
                 (encrypt ? EVP_EncryptInit_ex(ctx, cipherOf(suite), nullptr, k, nullptr)
                          : EVP_DecryptInit_ex(ctx, cipherOf(suite), nullptr, k, nullptr)) == 1;
  if (!ok) {
    EVP_CIPHER_CTX_free(ctx);
    throw std::runtime_error("the record cipher cannot be set up (libcrypto)");
  }
  return ctx;
}

// The tag, read and set through the cipher's parameters (what
// EVP_CIPHER_CTX_ctrl's EVP_CTRL_AEAD_GET_TAG and _SET_TAG translate to in
// OpenSSL 3, without the translation each record): the same parameter for
// both AEADs.
bool getTag(EVP_CIPHER_CTX* ctx, unsigned char* tag, std::size_t bytes) {
  OSSL_PARAM params[] = {OSSL_PARAM_construct_octet_string(OSSL_CIPHER_PARAM_AEAD_TAG, tag, bytes),
                         OSSL_PARAM_construct_end()};
  return EVP_CIPHER_CTX_get_params(ctx, params) == 1;
}

bool setTag(EVP_CIPHER_CTX* ctx, unsigned char* tag, std::size_t bytes) {
  OSSL_PARAM params[] = {OSSL_PARAM_construct_octet_string(OSSL_CIPHER_PARAM_AEAD_TAG, tag, bytes),
                         OSSL_PARAM_construct_end()};
  return EVP_CIPHER_CTX_set_params(ctx, params) == 1;
}

}  // namespace

bool RecordCipher::aesAvailable() {
  initCrypto();
  return crypto_aead_aes256gcm_is_available() != 0;  // AES-NI and CLMUL
}

RecordCipher::RecordCipher(CipherSuite suite, std::string_view sendKey, std::string_view receiveKey)
    : suite_(suite), keys_(std::make_unique<Keys>()) {
  keys_->send = keyed(suite, sendKey, true);
  keys_->receive = keyed(suite, receiveKey, false);
}

RecordCipher::~RecordCipher() = default;

std::size_t RecordCipher::sealedBytes(std::size_t plainBytes) {
  const auto records = plainBytes == 0 ? 1 : (plainBytes + kMaxPlainBytes - 1) / kMaxPlainBytes;
  return plainBytes + records * kOverheadBytes;
}

void RecordCipher::seal(std::string_view plain, std::string& out) {
  const auto at = out.size();
  out.resize(at + sealedBytes(plain.size()));
  seal(plain, out.data() + at);
}

std::size_t RecordCipher::seal(std::string_view plain, char* out) {
  auto* record = reinterpret_cast<unsigned char*>(out);
  do {
    const auto n = std::min(plain.size(), kMaxPlainBytes);
    const auto length = static_cast<std::uint32_t>(n + kTagBytes);
    for (int i = 0; i < 4; ++i) record[i] = static_cast<unsigned char>(length >> (24 - 8 * i));
    unsigned char* text = record + kHeaderBytes;
    unsigned char nonce[12];
    nonceOf(sent_++, nonce);
    int written = 0, last = 0;
    auto* ctx = keys_->send;
    const bool ok =
        EVP_EncryptInit_ex(ctx, nullptr, nullptr, nullptr, nonce) == 1 &&
        EVP_EncryptUpdate(ctx, nullptr, &written, record, kHeaderBytes) == 1 &&
        EVP_EncryptUpdate(ctx, text, &written, reinterpret_cast<const unsigned char*>(plain.data()),
                          static_cast<int>(n)) == 1 &&
        EVP_EncryptFinal_ex(ctx, text + written, &last) == 1 && getTag(ctx, text + n, kTagBytes);
    if (!ok) throw std::runtime_error("sealing a record failed (libcrypto)");
    plain.remove_prefix(n);
    record = text + n + kTagBytes;
  } while (!plain.empty());
  return static_cast<std::size_t>(record - reinterpret_cast<unsigned char*>(out));
}

std::size_t RecordCipher::recordLength(const char* data, std::size_t available) {
  if (available < kHeaderBytes) return 0;
  std::uint32_t length = 0;
  for (int i = 0; i < 4; ++i) length = (length << 8) | static_cast<std::uint8_t>(data[i]);
  return kHeaderBytes + length;
}

RecordCipher::Open RecordCipher::open(const char* data, std::size_t available,
                                      std::size_t maxPlainBytes, char* plain,
                                      std::size_t& recordBytes, std::size_t& plainBytes,
                                      std::string& error) {
  const auto whole = recordLength(data, available);
  if (whole == 0) return Open::NeedMore;
  const auto length = whole - kHeaderBytes;
  if (length < kTagBytes + 1 || length > std::min(maxPlainBytes, kMaxPlainBytes) + kTagBytes) {
    error = "record length " + std::to_string(length) + " is out of range";
    return Open::Bad;
  }
  if (available < whole) return Open::NeedMore;
  const auto* record = reinterpret_cast<const unsigned char*>(data);
  const unsigned char* text = record + kHeaderBytes;
  const auto textBytes = length - kTagBytes;
  auto* out = reinterpret_cast<unsigned char*>(plain);
  unsigned char nonce[12];
  nonceOf(received_, nonce);
  unsigned char tag[kTagBytes];
  std::memcpy(tag, text + textBytes, kTagBytes);
  int written = 0, last = 0;
  auto* ctx = keys_->receive;
  const bool ok = EVP_DecryptInit_ex(ctx, nullptr, nullptr, nullptr, nonce) == 1 &&
                  EVP_DecryptUpdate(ctx, nullptr, &written, record, kHeaderBytes) == 1 &&
                  EVP_DecryptUpdate(ctx, out, &written, text, static_cast<int>(textBytes)) == 1 &&
                  setTag(ctx, tag, kTagBytes) &&
                  EVP_DecryptFinal_ex(ctx, out + written, &last) == 1;
  if (!ok) {
    error = "record " + std::to_string(received_) +
            " failed its integrity check (changed, replayed, reordered or wrongly keyed)";
    return Open::Bad;
  }
  ++received_;
  recordBytes = whole;
  plainBytes = textBytes;
  return Open::Opened;
}

}  // namespace peis::security
