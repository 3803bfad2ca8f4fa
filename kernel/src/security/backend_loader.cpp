// Loading the security module on first use; see backend.h. Where it looks,
// in order (docs/security.md, "The security module"):
//   1. $PEIS_SECURITY_MODULE, when set (and nowhere else then);
//   2. beside a shared libpeis-kernel: <its dir>/peis/libpeis-security.so;
//   3. beside the running program, as installed: <bin>/../<libdir>/peis/;
//   4. the build tree's module (a program built with this tree);
//   5. the install prefix's (a program built elsewhere against the package).
// The first module of this kernel's version and revision is taken.
#include <dlfcn.h>
#include <unistd.h>

#include <atomic>
#include <climits>
#include <cstdlib>
#include <mutex>
#include <string>
#include <vector>

#include "peis/error.h"
#include "security/backend.h"

namespace peis::security {

namespace {

std::string directoryOf(const std::string& path) {
  const auto slash = path.rfind('/');
  return slash == std::string::npos ? std::string(".") : path.substr(0, slash);
}

std::vector<std::string> candidates() {
  if (const char* chosen = std::getenv("PEIS_SECURITY_MODULE"); chosen != nullptr && *chosen) {
    return {chosen};
  }
  std::vector<std::string> out;
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&backendLoaded), &info) != 0 && info.dli_fname != nullptr) {
    const std::string self = info.dli_fname;
    if (self.find(".so") != std::string::npos) {
      out.push_back(directoryOf(self) + "/peis/" PEIS_SECURITY_MODULE_NAME);
    }
  }
  char exe[PATH_MAX];
  const auto n = ::readlink("/proc/self/exe", exe, sizeof exe - 1);
  if (n > 0) {
    out.push_back(directoryOf(std::string(exe, static_cast<std::size_t>(n))) +
                  "/" PEIS_SECURITY_MODULE_FROM_BIN "/" PEIS_SECURITY_MODULE_NAME);
  }
  out.push_back(PEIS_SECURITY_MODULE_BUILD_PATH);
  out.push_back(PEIS_SECURITY_MODULE_INSTALL_PATH);
  return out;
}

struct Loaded {
  const Backend* table = nullptr;
  std::string problem;
};

Loaded load() {
  Loaded result;
  std::string tried;
  for (const auto& path : candidates()) {
    if (::access(path.c_str(), R_OK) != 0) {
      tried += "\n  " + path + ": none";
      continue;
    }
    // RTLD_LOCAL: its libraries' symbols stay its own.
    void* handle = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (handle == nullptr) {
      const char* why = ::dlerror();
      tried += "\n  " + path + ": " + (why != nullptr ? why : "cannot be loaded");
      continue;
    }
    const auto entry = reinterpret_cast<BackendEntry>(::dlsym(handle, kBackendEntryName));
    const Backend* table = entry != nullptr ? entry(PEIS_VERSION, kBackendRevision) : nullptr;
    if (table == nullptr || table->revision != kBackendRevision || table->size != sizeof(Backend)) {
      ::dlclose(handle);
      tried += "\n  " + path + ": another version's module";
      continue;
    }
    if (table->init() != 0) {
      tried += "\n  " + path + ": libsodium cannot be initialised";
      continue;  // the handle stays: its libraries may have done something
    }
    result.table = table;  // the handle stays open for the process's life
    return result;
  }
  result.problem = "a secured ecology needs the security module " PEIS_SECURITY_MODULE_NAME
                   " of PEIS " PEIS_VERSION ", not found (set PEIS_SECURITY_MODULE to its path):" +
                   tried;
  return result;
}

std::once_flag loadOnce;
Loaded loaded;                                     // written once, under loadOnce
std::atomic<const Backend*> loadedTable{nullptr};  // for backendLoaded()

}  // namespace

const Backend& backend() {
  std::call_once(loadOnce, [] {
    loaded = load();
    loadedTable.store(loaded.table, std::memory_order_release);
  });
  if (loaded.table == nullptr) throw Error(ErrorCode::InvalidConfig, loaded.problem);
  return *loaded.table;
}

bool backendLoaded() { return loadedTable.load(std::memory_order_acquire) != nullptr; }

}  // namespace peis::security
