// GLSL 4.50 shaders of the renderer (assemble_shader / raycast_fragment_source output, starting
// with the `#version 450 core` preamble) as GLSL ES 3.00, for WebGL2 (viewer/) and engines on
// OpenGL ES.
#pragma once
#include <string>

namespace raywarp::gl {

// `glsl450_source` with its #version line replaced by `#version 300 es` and highp default
// precision statements for every type ES 3.00 gives none or a lower one (float, int and every
// sampler type of ES 3.00), followed by `#line 2 0`, so the lines after the preamble keep their
// numbers (the assembler's `#line L S` directives stay as they are: ES 3.00 reads them as 3.30+
// does). Nothing else changes: the renderer's shaders are written in the common subset of GLSL
// 4.50 and ES 3.00 (explicit float literals, no implicit conversions, layout locations only on
// vertex inputs and fragment outputs), so the source compiles in both with the same meaning
// (highp is IEEE single precision, as GLSL 4.50's float). A source with no #version line gets the
// ES preamble in front. Throws Error for a #version other than 450 (core), or a source that uses
// what ES 3.00 lacks and the renderer never writes (double, layout(binding), #extension).
std::string glsl_es_300(const std::string& glsl450_source);

}  // namespace raywarp::gl
