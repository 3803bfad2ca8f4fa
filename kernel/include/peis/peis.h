// The whole public API of the PEIS-kernel in one include. The component
// conventions (Component, Descriptor) are the component library's:
// <peis/component.h>.
#pragma once

#include "peis/credentials.h"
#include "peis/error.h"
#include "peis/kernel.h"
#include "peis/key.h"
#include "peis/log.h"
#include "peis/options.h"
#include "peis/pattern.h"
#include "peis/tuple.h"
#include "peis/types.h"
