// Breaks the layering on purpose: the deformers know nothing of the editor, nor of windows or UI.
#include <imgui.h>

int deformer_uses_imgui() { return 0; }
