// The records' AEAD in the security module; see record_aead.h.
//
// AES-256-GCM has two implementations here that seal the same bytes: the
// one of libgcrypt (its VAES code works on 256-bit registers) and, where
// the module was built with it (x86-64) and the CPU has AVX-512 with VAES
// and VPCLMULQDQ, the one of Intel's ipsec-mb (on 512-bit registers).
// Which is faster depends on the CPU: on an Intel Xeon with AVX-512
// ipsec-mb's sealed a 16 KiB record in 1.3 µs against libgcrypt's 3.1 µs;
// on CPUs that split 512-bit operations in two it may not win. So the
// first AES context of a process measures both (a few records, about
// 0.15 ms once) and takes the faster, as Linux picks its RAID-6 code at
// boot; both sealing the same records is checked at the same time, and
// $PEIS_RECORD_AEAD (`libgcrypt` or `ipsec-mb`) overrides the measurement.
#include "security/module/record_aead.h"

#include <gcrypt.h>
#include <sodium.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <new>
#include <string_view>
#include <vector>

#ifdef PEIS_HAVE_IPSEC_MB
#include <intel-ipsec-mb.h>
#endif

namespace peis::security {

// A libgcrypt handle keyed once, each record setting its nonce (closing it
// wipes the expanded key); or ipsec-mb's expanded keys, which every record
// is sealed with in one call.
struct AeadContext {
  gcry_cipher_hd_t handle = nullptr;
#ifdef PEIS_HAVE_IPSEC_MB
  gcm_key_data* gcm = nullptr;
#endif
};

namespace module {
namespace {

// libgcrypt is initialised once per process, on the first AEAD (a
// function-local static: thread-safe), unless the program did it first; a
// PEIS that only signs (`peis keys`) never does. No secure memory: the keys
// live in ordinary memory, as libsodium's do, and are wiped on close.
bool gcryptReady() {
  static const bool ready = [] {
    if (gcry_control(GCRYCTL_INITIALIZATION_FINISHED_P) != 0) return true;
    if (gcry_check_version(GCRYPT_VERSION) == nullptr) return false;  // older than the headers
    gcry_control(GCRYCTL_DISABLE_SECMEM, 0);
    gcry_control(GCRYCTL_INITIALIZATION_FINISHED, 0);
    return true;
  }();
  return ready;
}

AeadContext* newLibgcrypt(bool aes, const unsigned char* key) {
  if (!gcryptReady()) return nullptr;
  gcry_cipher_hd_t handle = nullptr;
  const bool ok =
      gcry_cipher_open(&handle, aes ? GCRY_CIPHER_AES256 : GCRY_CIPHER_CHACHA20,
                       aes ? GCRY_CIPHER_MODE_GCM : GCRY_CIPHER_MODE_POLY1305, 0) == 0 &&
      gcry_cipher_setkey(handle, key, 32) == 0;
  auto* context = ok ? new (std::nothrow) AeadContext{} : nullptr;
  if (context == nullptr) {
    gcry_cipher_close(handle);  // nullptr: nothing
    return nullptr;
  }
  context->handle = handle;
  return context;
}

#ifdef PEIS_HAVE_IPSEC_MB
// AVX-512F and VL (with the system's support of their registers, which
// the compiler's check includes), VAES and VPCLMULQDQ: CPUID leaf 7, ECX
// bits 9 and 10 (compilers' __builtin_cpu_supports does not know these
// two everywhere: clang 14).
bool cpuHasAvx512Vaes() {
#if defined(__x86_64__)
  if (!__builtin_cpu_supports("avx512f") || !__builtin_cpu_supports("avx512vl")) return false;
  unsigned eax = 7, ebx = 0, ecx = 0, edx = 0;
  __asm__("cpuid" : "+a"(eax), "=b"(ebx), "+c"(ecx), "=d"(edx));
  return ((ecx >> 9) & 1) != 0 && ((ecx >> 10) & 1) != 0;
#else
  return false;
#endif
}

// ipsec-mb's AES-256-GCM where the CPU runs its AVX-512 VAES/VPCLMULQDQ
// code: the functions, taken from a manager that is freed at once (the
// direct GCM calls keep no state in it). Elsewhere it is not considered:
// its SSE and AVX2 code sealed 16 KiB no faster than libgcrypt's here, and
// setting up a manager costs about 0.5 ms and maps about 3.4 MiB of its
// code (shared between processes).
struct IpsecMb {
  aes_gcm_pre_t expandKey = nullptr;
  aes_gcm_enc_dec_t seal = nullptr;
  aes_gcm_enc_dec_t open = nullptr;
  const char* name = nullptr;
};

const IpsecMb& ipsecMb() {
  static const IpsecMb found = [] {
    IpsecMb out;
    if (!cpuHasAvx512Vaes()) return out;
    IMB_MGR* manager = alloc_mb_mgr(0);
    if (manager == nullptr) return out;
    IMB_ARCH arch = IMB_ARCH_NONE;
    init_mb_mgr_auto(manager, &arch);
    const auto vaes = IMB_FEATURE_VAES | IMB_FEATURE_VPCLMULQDQ;
    if (arch == IMB_ARCH_AVX512 && (manager->features & vaes) == vaes &&
        imb_get_errno(manager) == 0) {
      out.name = "ipsec-mb (AVX-512, VAES)";
      out.expandKey = manager->gcm256_pre;
      out.seal = manager->gcm256_enc;
      out.open = manager->gcm256_dec;
    }
    free_mb_mgr(manager);
    return out;
  }();
  return found;
}

AeadContext* newIpsecMb(const unsigned char* key) {
  const auto& ipsec = ipsecMb();
  if (ipsec.name == nullptr) return nullptr;
  auto* context = new (std::nothrow) AeadContext{};
  auto* keys = new (std::nothrow) gcm_key_data;  // 64-byte aligned (its type says so)
  if (context == nullptr || keys == nullptr) {
    delete context;
    delete keys;
    return nullptr;
  }
  ipsec.expandKey(key, keys);
  context->gcm = keys;
  return context;
}
#endif

// Seals `rounds` times a record of 1 KiB and one of 16 KiB with both
// implementations, interleaved; the smaller sum of the fastest times wins
// (a round that the scheduler interrupted drops out). Both must seal the
// same bytes, else libgcrypt's is taken alone.
AeadImplementation measureFaster() {
#ifdef PEIS_HAVE_IPSEC_MB
  constexpr std::size_t kSizes[] = {1024, 16 * 1024};
  constexpr int kRounds = 8;
  unsigned char key[32];
  randombytes_buf(key, sizeof key);
  AeadContext* contexts[] = {newLibgcrypt(true, key), newIpsecMb(key)};
  std::vector<unsigned char> text(kSizes[1]), sealed[2];
  randombytes_buf(text.data(), text.size());
  unsigned char tags[2][16], nonce[12] = {}, ad[4] = {};
  double best[2][2] = {{1e30, 1e30}, {1e30, 1e30}};
  bool same = contexts[0] != nullptr && contexts[1] != nullptr;
  for (int round = 0; same && round < kRounds; ++round) {
    for (int size = 0; size < 2; ++size) {
      for (int which = 0; which < 2; ++which) {
        sealed[which].resize(kSizes[size]);
        const auto start = std::chrono::steady_clock::now();
        same = same && aeadSeal(contexts[which], nonce, ad, sizeof ad, text.data(), kSizes[size],
                                sealed[which].data(), tags[which]);
        const std::chrono::duration<double> took = std::chrono::steady_clock::now() - start;
        best[which][size] = std::min(best[which][size], took.count());
      }
      same = same && sealed[0] == sealed[1] && std::memcmp(tags[0], tags[1], 16) == 0;
    }
  }
  aeadFree(contexts[0]);
  aeadFree(contexts[1]);
  if (same && best[1][0] + best[1][1] < best[0][0] + best[0][1]) {
    return AeadImplementation::Aes256GcmIpsecMb;
  }
#endif
  return AeadImplementation::Aes256GcmLibgcrypt;
}

// AES-256-GCM's implementation in this process, chosen once.
AeadImplementation fasterAes() {
  static const AeadImplementation chosen = [] {
    if (!gcryptReady()) return AeadImplementation::Aes256GcmLibgcrypt;
    const char* named = std::getenv("PEIS_RECORD_AEAD");
    const std::string_view wanted = named != nullptr ? named : "";
    if (wanted == "libgcrypt" || aeadName(AeadImplementation::Aes256GcmIpsecMb) == nullptr) {
      return AeadImplementation::Aes256GcmLibgcrypt;
    }
    if (wanted == "ipsec-mb") return AeadImplementation::Aes256GcmIpsecMb;
    return measureFaster();
  }();
  return chosen;
}

}  // namespace

AeadContext* aeadNew(AeadImplementation implementation, const unsigned char* key) {
  switch (implementation) {
    case AeadImplementation::Aes256Gcm:
      return aeadNew(fasterAes(), key);
    case AeadImplementation::Aes256GcmLibgcrypt:
      return newLibgcrypt(true, key);
    case AeadImplementation::Aes256GcmIpsecMb:
#ifdef PEIS_HAVE_IPSEC_MB
      return newIpsecMb(key);
#else
      return nullptr;
#endif
    case AeadImplementation::ChaCha20Poly1305:
      return newLibgcrypt(false, key);
  }
  return nullptr;
}

const char* aeadName(AeadImplementation implementation) {
  switch (implementation) {
    case AeadImplementation::Aes256Gcm:
      return aeadName(fasterAes());
    case AeadImplementation::Aes256GcmLibgcrypt:
    case AeadImplementation::ChaCha20Poly1305:
      return "libgcrypt";
    case AeadImplementation::Aes256GcmIpsecMb:
#ifdef PEIS_HAVE_IPSEC_MB
      return ipsecMb().name;
#else
      return nullptr;
#endif
  }
  return nullptr;
}

void aeadFree(AeadContext* context) {
  if (context == nullptr) return;
  if (context->handle != nullptr) gcry_cipher_close(context->handle);  // wipes the expanded key
#ifdef PEIS_HAVE_IPSEC_MB
  if (context->gcm != nullptr) {
    sodium_memzero(context->gcm, sizeof *context->gcm);
    delete context->gcm;
  }
#endif
  delete context;
}

bool aeadSeal(AeadContext* context, const unsigned char* nonce, const unsigned char* ad,
              std::size_t adBytes, const unsigned char* text, std::size_t bytes, unsigned char* out,
              unsigned char* tag) {
#ifdef PEIS_HAVE_IPSEC_MB
  if (context->gcm != nullptr) {
    gcm_context_data state;
    ipsecMb().seal(context->gcm, &state, out, text, bytes, nonce, ad, adBytes, tag, 16);
    return true;
  }
#endif
  auto* handle = context->handle;
  return gcry_cipher_setiv(handle, nonce, 12) == 0 &&
         gcry_cipher_authenticate(handle, ad, adBytes) == 0 &&
         gcry_cipher_encrypt(handle, out, bytes, text, bytes) == 0 &&
         gcry_cipher_gettag(handle, tag, 16) == 0;
}

// The tag is checked in constant time; a failed one leaves `out` written
// but not to be taken (the link closes).
bool aeadOpen(AeadContext* context, const unsigned char* nonce, const unsigned char* ad,
              std::size_t adBytes, const unsigned char* text, std::size_t bytes, unsigned char* out,
              unsigned char* tag) {
#ifdef PEIS_HAVE_IPSEC_MB
  if (context->gcm != nullptr) {
    gcm_context_data state;
    unsigned char computed[16];
    ipsecMb().open(context->gcm, &state, out, text, bytes, nonce, ad, adBytes, computed, 16);
    return sodium_memcmp(computed, tag, 16) == 0;
  }
#endif
  auto* handle = context->handle;
  return gcry_cipher_setiv(handle, nonce, 12) == 0 &&
         gcry_cipher_authenticate(handle, ad, adBytes) == 0 &&
         gcry_cipher_decrypt(handle, out, bytes, text, bytes) == 0 &&
         gcry_cipher_checktag(handle, tag, 16) == 0;
}

}  // namespace module
}  // namespace peis::security
