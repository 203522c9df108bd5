// Breaks the layering on purpose: library/ knows nothing of the command line (or the editor).
#include "cli/export.h"

int library_uses_cli() { return 0; }
