// RecordCipher: AEAD records of a secured link; see record_cipher.h.
#include "security/record_cipher.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>

#include "security/backend.h"

namespace peis::security {

// One AEAD context per direction, in the security module.
struct RecordCipher::Keys {
  AeadContext* send = nullptr;
  AeadContext* receive = nullptr;
  ~Keys() {
    if (send != nullptr) backend().aeadFree(send);  // frees the expanded keys (cleansed)
    if (receive != nullptr) backend().aeadFree(receive);
  }
};

namespace {

void nonceOf(std::uint64_t counter, unsigned char nonce[12]) {
  std::memset(nonce, 0, 4);
  for (int i = 0; i < 8; ++i) nonce[4 + i] = static_cast<unsigned char>(counter >> (56 - 8 * i));
}

AeadImplementation implementationOf(CipherSuite suite, AeadImplementation aes) {
  return suite == CipherSuite::Aes256Gcm ? aes : AeadImplementation::ChaCha20Poly1305;
}

AeadContext* keyed(AeadImplementation implementation, std::string_view key) {
  if (key.size() != 32) throw std::runtime_error("the record cipher needs a 32-byte key");
  auto* context =
      backend().aeadNew(implementation, reinterpret_cast<const unsigned char*>(key.data()));
  if (context == nullptr) throw std::runtime_error("the record cipher cannot be set up");
  return context;
}

}  // namespace

bool RecordCipher::aesAvailable() { return backend().aesAvailable(); }

std::string RecordCipher::implementation(CipherSuite suite, AeadImplementation aes) {
  const char* name = backend().aeadName(implementationOf(suite, aes));
  return name != nullptr ? name : "";
}

RecordCipher::RecordCipher(CipherSuite suite, std::string_view sendKey, std::string_view receiveKey,
                           AeadImplementation aes)
    : suite_(suite), keys_(std::make_unique<Keys>()) {
  keys_->send = keyed(implementationOf(suite, aes), sendKey);
  keys_->receive = keyed(implementationOf(suite, aes), receiveKey);
}

RecordCipher::~RecordCipher() = default;

std::size_t RecordCipher::sealedBytes(std::size_t plainBytes) {
  const auto records = plainBytes == 0 ? 1 : (plainBytes + kMaxPlainBytes - 1) / kMaxPlainBytes;
  return plainBytes + records * kOverheadBytes;
}

std::size_t RecordCipher::plainFitting(std::size_t recordBytes) {
  constexpr auto kWhole = kMaxPlainBytes + kOverheadBytes;
  const auto rest = recordBytes % kWhole;
  return recordBytes / kWhole * kMaxPlainBytes +
         (rest > kOverheadBytes ? rest - kOverheadBytes : 0);
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
    const bool ok =
        backend().aeadSeal(keys_->send, nonce, record, kHeaderBytes,
                           reinterpret_cast<const unsigned char*>(plain.data()), n, text, text + n);
    if (!ok) throw std::runtime_error("sealing a record failed");
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
  const bool ok =
      backend().aeadOpen(keys_->receive, nonce, record, kHeaderBytes, text, textBytes, out, tag);
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
