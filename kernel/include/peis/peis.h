// The whole public API of the PEIS-kernel in one include.
#pragma once

#include "peis/component.h"
#include "peis/descriptor.h"
#include "peis/error.h"
#include "peis/kernel.h"
#include "peis/key.h"
#include "peis/options.h"
#include "peis/pattern.h"
#include "peis/tuple.h"
#include "peis/types.h"
