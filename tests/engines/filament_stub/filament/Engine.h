// Stands for Filament's Engine only so that docs/exports.md's Filament snippet compiles in
// test_engine_exports; nothing of Filament runs.
#pragma once

namespace filament {
class Engine {};
} // namespace filament
