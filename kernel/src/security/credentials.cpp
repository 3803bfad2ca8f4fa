// Credentials files and trust roots, and the public functions of
// peis/credentials.h; see credentials.h.
#include "security/credentials.h"

#include <sys/stat.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <ctime>

#include "peis/credentials.h"
#include "peis/error.h"
#include "peis/key.h"
#include "security/crypto.h"
#include "security/yaml_file.h"

namespace peis::security {

namespace {

std::int64_t unixNow() {
  return std::chrono::duration_cast<std::chrono::seconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::string isoTime(std::int64_t seconds) {
  const std::time_t t = seconds;
  std::tm tm{};
  gmtime_r(&t, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

std::string list(const std::vector<std::string>& items) {
  std::string out = "[";
  for (const auto& item : items) out += (out.size() > 1 ? ", " : "") + item;
  return out + "]";
}

}  // namespace

TrustRoot readTrustRootFile(const std::string& file) {
  YamlFile yaml(file);
  const auto root = yaml.load();
  yaml.onlyKeys(root, {"peis-trust-root", "ecology", "public-key", "secret-key"}, "a trust root");
  if (yaml.text(yaml.required(root, "peis-trust-root", "a trust root"), "peis-trust-root") != "1") {
    yaml.fail(root["peis-trust-root"], "a trust root of another version");
  }
  TrustRoot t;
  t.ecology = yaml.text(yaml.required(root, "ecology", "a trust root"), "ecology");
  t.publicKey = yaml.hexBytes(yaml.required(root, "public-key", "a trust root"),
                              kSignPublicKeyBytes, "public-key");
  t.secretKey = yaml.hexBytes(yaml.required(root, "secret-key", "a trust root"),
                              kSignSecretKeyBytes, "secret-key");
  if (!keysMatch(t.publicKey, t.secretKey)) {
    yaml.fail(root["secret-key"], "the secret key does not belong to the public key");
  }
  return t;
}

std::string trustRootText(const TrustRoot& t) {
  return "# The trust root of the secured PEIS ecology '" + t.ecology +
         "' (docs/security.md).\n"
         "# Keep it secret and offline: whoever holds it can admit anybody to the ecology.\n"
         "# Fingerprint " +
         fingerprint(t.publicKey) +
         ".\n"
         "peis-trust-root: 1\n"
         "ecology: " +
         t.ecology + "\npublic-key: " + toHex(t.publicKey) + "\nsecret-key: " + toHex(t.secretKey) +
         "\n";
}

Credentials readCredentials(const std::string& file) {
  YamlFile yaml(file);
  const auto root = yaml.load();
  if (!root.isMap() || !root["peis-credentials"]) {
    yaml.fail(root, "not a PEIS credentials file (no 'peis-credentials'; see docs/security.md)");
  }
  yaml.onlyKeys(root, {"peis-credentials", "root", "certificate", "secret-key"},
                "a credentials file");
  if (yaml.text(root["peis-credentials"], "peis-credentials") != "1") {
    yaml.fail(root["peis-credentials"], "credentials of another version");
  }
  Credentials c;
  c.file = file;
  c.rootKey =
      yaml.hexBytes(yaml.required(root, "root", "a credentials file"), kSignPublicKeyBytes, "root");
  const auto certificateNode = yaml.required(root, "certificate", "a credentials file");
  const auto bytes = fromHex(yaml.text(certificateNode, "certificate"));
  if (!bytes) yaml.fail(certificateNode, "certificate must be hex");
  std::string_view in = *bytes;
  std::string error;
  auto certificate = decodeCertificate(in, error);
  if (!certificate || !in.empty()) {
    yaml.fail(certificateNode, "broken certificate: " + (error.empty() ? "trailing bytes" : error));
  }
  c.certificate = std::move(*certificate);
  if (auto problem =
          certificateProblem(c.certificate, c.rootKey, c.certificate.ecology, unixNow())) {
    yaml.fail(certificateNode, "the certificate cannot be used: " + *problem);
  }
  c.secretKey = yaml.hexBytes(yaml.required(root, "secret-key", "a credentials file"),
                              kSignSecretKeyBytes, "secret-key");
  if (!keysMatch(c.certificate.publicKey, c.secretKey)) {
    yaml.fail(root["secret-key"], "the secret key does not belong to the certificate");
  }
  return c;
}

std::string credentialsText(const Credentials& c) {
  const auto& cert = c.certificate;
  std::string text =
      "# PEIS credentials (docs/security.md). Keep this file secret: whoever holds it\n"
      "# joins the secured ecology '" +
      cert.ecology + "' as principal '" + cert.principal +
      "'.\n"
      "# What the certificate below says (signed by the trust root; editing these\n"
      "# comments changes nothing):\n"
      "#   principal " +
      cert.principal + "\n#   groups    " + list(cert.groups) + "\n#   names     " +
      list(cert.names) + "\n";
  if (cert.pinnedId != 0) text += "#   id        " + std::to_string(cert.pinnedId) + "\n";
  text += "#   issued    " + isoTime(cert.issued) + "\n#   expires   " +
          (cert.notAfter == 0 ? std::string("never") : isoTime(cert.notAfter)) +
          "\n#   serial    " + serialText(cert.serial) + "\n#   root      " +
          fingerprint(c.rootKey) +
          "\n"
          "peis-credentials: 1\n"
          "root: " +
          toHex(c.rootKey) + "\ncertificate: " + toHex(encodeCertificate(cert)) +
          "\nsecret-key: " + toHex(c.secretKey) + "\n";
  return text;
}

void applyCredentials(const Credentials& c, Options& options, const std::string& defaultName) {
  const auto& cert = c.certificate;
  const auto where = " (credentials " + c.file + ", " + describe(cert) + ")";
  if (options.ecology == "default") {
    options.ecology = cert.ecology;
  } else if (options.ecology != cert.ecology) {
    throw Error(ErrorCode::InvalidArgument, "--peis-ecology: '" + options.ecology +
                                                "', but the credentials are for '" + cert.ecology +
                                                "'" + where);
  }
  if (cert.pinnedId != 0) {
    if (options.id && *options.id != cert.pinnedId) {
      throw Error(ErrorCode::InvalidArgument, "--peis-id: " + std::to_string(*options.id) +
                                                  ", but the credentials pin id " +
                                                  std::to_string(cert.pinnedId) + where);
    }
    options.id = cert.pinnedId;
  }
  std::string names;
  for (const auto& n : cert.names) names += (names.empty() ? "" : ", ") + n;
  if (!options.name.empty()) {
    if (!allowsName(cert, options.name)) {
      throw Error(ErrorCode::InvalidArgument, "--peis-name: '" + options.name +
                                                  "' is not a name the credentials allow (" +
                                                  names + ")" + where);
    }
  } else if (allowsName(cert, defaultName)) {
    options.name = defaultName;
  } else if (allowsName(cert, cert.principal)) {
    options.name = cert.principal;
  } else {
    for (const auto& n : cert.names) {
      if (!n.empty() && n.back() != '*') options.name = n;
    }
    if (options.name.empty()) {
      throw Error(ErrorCode::InvalidArgument,
                  "--peis-name: give a name the credentials allow (" + names + ")" + where);
    }
  }
}

CredentialsInfo infoOf(const Credentials& c) {
  const auto& cert = c.certificate;
  CredentialsInfo info;
  info.file = c.file;
  info.ecology = cert.ecology;
  info.principal = cert.principal;
  info.groups = cert.groups;
  info.names = cert.names;
  info.pinnedId = cert.pinnedId;
  info.issued = isoTime(cert.issued);
  info.expires = cert.notAfter == 0 ? std::string() : isoTime(cert.notAfter);
  info.serial = serialText(cert.serial);
  info.rootFingerprint = fingerprint(c.rootKey);
  info.keyFingerprint = fingerprint(cert.publicKey);
  return info;
}

}  // namespace peis::security

namespace peis {

using namespace security;

namespace {

std::string rootFile(const std::string& directory) { return directory + "/root.key"; }

void checkName(const std::string& what, const std::string& name) {
  if (auto problem = nameProblem(name)) {
    throw Error(ErrorCode::InvalidArgument, what + " '" + name + "': " + *problem);
  }
}

}  // namespace

TrustRootInfo createTrustRoot(const std::string& directory, const std::string& ecology) {
  if (ecology.empty() || ecology.size() > kMaxNameBytes) {
    throw Error(ErrorCode::InvalidArgument, "the ecology name must be 1..64 bytes");
  }
  for (char c : ecology) {
    if (static_cast<unsigned char>(c) <= 0x20 || static_cast<unsigned char>(c) >= 0x7f) {
      throw Error(ErrorCode::InvalidArgument,
                  "the ecology name may only hold printable characters");
    }
  }
  if (::mkdir(directory.c_str(), 0700) != 0 && errno != EEXIST) {
    throw Error(ErrorCode::InvalidArgument,
                directory + ": cannot be created: " + std::string(std::strerror(errno)));
  }
  TrustRoot root;
  root.ecology = ecology;
  auto keys = newSignKeyPair();
  root.publicKey = keys.publicKey;
  root.secretKey = keys.secretKey;
  writeSecretFile(rootFile(directory), trustRootText(root));
  return TrustRootInfo{ecology, fingerprint(root.publicKey), rootFile(directory)};
}

TrustRootInfo readTrustRoot(const std::string& directory) {
  const auto root = readTrustRootFile(rootFile(directory));
  return TrustRootInfo{root.ecology, fingerprint(root.publicKey), rootFile(directory)};
}

CredentialsInfo issueCredentials(const std::string& directory, const CredentialsRequest& request) {
  checkName("the principal", request.principal);
  for (const auto& g : request.groups) checkName("the group", g);
  auto names = request.names.empty() ? std::vector<std::string>{request.principal} : request.names;
  for (const auto& n : names) {
    if (n == "*") continue;
    checkName("the name pattern", !n.empty() && n.back() == '*' ? n.substr(0, n.size() - 1) : n);
  }
  if (request.pinnedId && !isValidPeisId(*request.pinnedId)) {
    throw Error(ErrorCode::InvalidArgument, "the id must be in 1..2147483647");
  }
  if (request.validDays < 0 || request.validDays > 36500) {
    throw Error(ErrorCode::InvalidArgument, "the validity must be 0..36500 days");
  }
  const auto root = readTrustRootFile(rootFile(directory));
  Credentials c;
  c.rootKey = root.publicKey;
  auto keys = newSignKeyPair();
  c.secretKey = keys.secretKey;
  auto& cert = c.certificate;
  cert.ecology = root.ecology;
  cert.publicKey = keys.publicKey;
  cert.principal = request.principal;
  cert.groups = request.groups;
  cert.names = names;
  cert.pinnedId = request.pinnedId.value_or(0);
  const auto now = std::chrono::duration_cast<std::chrono::seconds>(
                       std::chrono::system_clock::now().time_since_epoch())
                       .count();
  cert.issued = now;
  cert.notAfter = request.validDays == 0 ? 0 : now + std::int64_t{request.validDays} * 86400;
  cert.serial = randomU64();
  signCertificate(cert, root.secretKey);
  c.file = request.file.empty() ? directory + "/" + request.principal + ".cred" : request.file;
  writeSecretFile(c.file, credentialsText(c), request.replace);
  return infoOf(c);
}

CredentialsInfo readCredentialsInfo(const std::string& file) {
  return infoOf(readCredentials(file));
}

RadioKeysInfo createRadioKeys(const std::string& directory, const std::vector<int>& nodes,
                              bool replace) {
  if (::mkdir(directory.c_str(), 0700) != 0 && errno != EEXIST) {
    throw Error(ErrorCode::InvalidArgument,
                directory + ": cannot be created: " + std::string(std::strerror(errno)));
  }
  RadioKeysInfo info;
  info.file = directory + "/radio.yaml";
  info.bridgeKey = toHex(randomBytes(16));
  std::string text =
      "# The keys of a secured tiny radio (docs/security.md): the tinybridge's\n"
      "# (peis-tinybridge --radio-keys FILE) and one per tiny node it vouches for.\n"
      "# Keep it secret: whoever holds a node's key can speak for that node.\n"
      "bridge: " +
      info.bridgeKey + "\nnodes:\n";
  for (const int node : nodes) {
    if (node < 1 || node > 0xFFFE) {
      throw Error(ErrorCode::InvalidArgument,
                  "tiny node id " + std::to_string(node) + " is not in 1..65534");
    }
    info.nodeKeys.emplace_back(node, toHex(randomBytes(16)));
    text += "  " + std::to_string(node) + ": " + info.nodeKeys.back().second + "\n";
  }
  writeSecretFile(info.file, text, replace);
  return info;
}

}  // namespace peis
