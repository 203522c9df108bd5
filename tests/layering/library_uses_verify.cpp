// Breaks the layering on purpose: the core library does not depend on the verification code.
#include "verify/reference.h"

int library_uses_verify() { return 0; }
