// Credentials and trust roots as the kernel uses them: read from and written
// to their YAML files (docs/security.md shows both), checked on reading.
// The public functions of peis/credentials.h (the `peis keys` command) are
// built on these.
#pragma once

#include <string>

#include "peis/credentials.h"
#include "peis/options.h"
#include "security/certificate.h"

namespace peis::security {

struct TrustRoot {
  std::string ecology;
  std::string publicKey;  // Ed25519, 32 bytes
  std::string secretKey;  // 64 bytes
};
struct Credentials {
  Certificate certificate;
  std::string secretKey;  // the holder's, 64 bytes
  std::string rootKey;    // the trust root's public key
  std::string file;
};

TrustRoot readTrustRootFile(const std::string& file);
std::string trustRootText(const TrustRoot& root);
// Reads and checks a credentials file: its certificate signed by the root
// it names, its secret key the certificate's. Throws Error(InvalidConfig)
// naming file:line.
Credentials readCredentials(const std::string& file);
std::string credentialsText(const Credentials& credentials);
// Fits a PEIS's options to its credentials: the ecology they are for (unless
// another is asked for: an error), the id they pin, and a name they allow —
// the one asked for, else `defaultName`, else the principal's. Throws
// Error(InvalidArgument) naming the flag and the credentials file.
void applyCredentials(const Credentials& credentials, Options& options,
                      const std::string& defaultName);
CredentialsInfo infoOf(const Credentials& credentials);

}  // namespace peis::security
