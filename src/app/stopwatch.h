// The commands' stopwatch is common/stopwatch.h, which the device code times its phases with too.
#pragma once
#include "common/stopwatch.h"
