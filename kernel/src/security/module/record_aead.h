// The records' AEAD inside the security module (the aead* entries of the
// Backend table, backend.h): AES-256-GCM by libgcrypt or by Intel's
// ipsec-mb, whichever seals faster on this CPU, and ChaCha20-Poly1305 by
// libgcrypt. See record_aead.cpp and docs/security.md, "What it costs".
#pragma once

#include <cstddef>

#include "security/backend.h"

namespace peis::security::module {

AeadContext* aeadNew(AeadImplementation implementation, const unsigned char* key);
const char* aeadName(AeadImplementation implementation);
void aeadFree(AeadContext* context);
bool aeadSeal(AeadContext* context, const unsigned char* nonce, const unsigned char* ad,
              std::size_t adBytes, const unsigned char* text, std::size_t bytes, unsigned char* out,
              unsigned char* tag);
bool aeadOpen(AeadContext* context, const unsigned char* nonce, const unsigned char* ad,
              std::size_t adBytes, const unsigned char* text, std::size_t bytes, unsigned char* out,
              unsigned char* tag);

}  // namespace peis::security::module
