// Breaks the layering on purpose: library/ knows nothing of the editor.
#include "editor/editor.h"

int library_uses_editor() { return 0; }
