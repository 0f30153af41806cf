// Fixture of the module-boundary check (tests/CMakeLists.txt, ModuleBoundariesCatchViolation): a
// frontend header that includes the backend must make the check fail. Never compiled.
#include "dfo_backend/window_optimizer.h"
