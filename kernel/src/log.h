// The kernel's log is public (programs on the kernel log alike): see
// peis/log.h. Kept so the kernel's sources include "log.h" as before.
#pragma once

#include "peis/log.h"
