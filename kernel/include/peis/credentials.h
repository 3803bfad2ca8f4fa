// Credentials of a secured ecology (docs/security.md). An administrator
// creates the ecology's trust root once and issues one credentials file
// per PEIS, or one for a group of PEIS; a PEIS given a credentials file
// (Options::credentials, --peis-credentials, PEIS_CREDENTIALS) joins that
// ecology only, over authenticated and encrypted links. The `peis keys`
// command is these functions; nothing here exposes the cryptography.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "peis/types.h"

namespace peis {

// A trust root: DIRECTORY/root.key (secret: it admits PEIS to the ecology).
struct TrustRootInfo {
  std::string ecology;
  std::string fingerprint;  // of its public key, as logs and `peis keys` show it
  std::string file;
};
// Creates `directory` (if needed) and its root.key for ecology `ecology`.
// Throws Error(InvalidArgument) if the directory already holds a root.
TrustRootInfo createTrustRoot(const std::string& directory, const std::string& ecology);
TrustRootInfo readTrustRoot(const std::string& directory);

struct CredentialsRequest {
  std::string principal;            // who holds it (its policy rules name it)
  std::vector<std::string> groups;  // the groups it belongs to
  // The PEIS names its holders may use: exact, or ending in '*' (a prefix;
  // "*" is any name). Empty: the principal's name only.
  std::vector<std::string> names;
  std::optional<PeisId> pinnedId;  // its holder always has this id
  int validDays = 365;             // 0: never expires
  std::string file;                // where to write it (default DIRECTORY/PRINCIPAL.cred)
  bool replace = false;            // overwrite an existing file
};
struct CredentialsInfo {
  std::string file;
  std::string ecology;
  std::string principal;
  std::vector<std::string> groups;
  std::vector<std::string> names;
  PeisId pinnedId = 0;
  std::string issued, expires;  // ISO 8601 UTC; expires empty: never
  std::string serial;           // hex
  std::string rootFingerprint;
  std::string keyFingerprint;
};
// Issues a credentials file signed by the trust root in `directory`.
// Throws Error(InvalidArgument) for a bad principal, group or name pattern,
// an existing file, or Error(InvalidConfig) for a broken root.key.
CredentialsInfo issueCredentials(const std::string& directory, const CredentialsRequest& request);
// What a credentials file says; throws Error(InvalidConfig) naming
// file:line when it is not one, or is broken.
CredentialsInfo readCredentialsInfo(const std::string& file);

// The keys of a secured tiny radio (docs/security.md): a random 16-byte key
// for the tinybridge and for each tiny node, written to DIRECTORY/radio.yaml
// (secret; the tinybridge's --radio-keys). Returns the file and, per node,
// its key in hex, with the bridge's (for the node's provisioning).
struct RadioKeysInfo {
  std::string file;
  std::string bridgeKey;
  std::vector<std::pair<int, std::string>> nodeKeys;
};
// Throws Error(InvalidArgument) for a node id outside 1..65534 or an
// existing file (unless `replace`).
RadioKeysInfo createRadioKeys(const std::string& directory, const std::vector<int>& nodes,
                              bool replace = false);

}  // namespace peis
