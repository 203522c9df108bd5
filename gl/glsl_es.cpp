#include "gl/glsl_es.h"

#include <iterator>
#include <regex>
#include <sstream>

#include "base/error.h"

namespace raywarp::gl {

namespace {

constexpr const char* kEsPreamble =
    "#version 300 es\n"
    "precision highp float;\n"
    "precision highp int;\n"
    "precision highp sampler2D;\n"
    "precision highp sampler3D;\n"
    "precision highp samplerCube;\n"
    "precision highp sampler2DArray;\n"
    "precision highp sampler2DShadow;\n"
    "precision highp samplerCubeShadow;\n"
    "precision highp sampler2DArrayShadow;\n"
    "precision highp isampler2D;\n"
    "precision highp isampler3D;\n"
    "precision highp isamplerCube;\n"
    "precision highp isampler2DArray;\n"
    "precision highp usampler2D;\n"
    "precision highp usampler3D;\n"
    "precision highp usamplerCube;\n"
    "precision highp usampler2DArray;\n";

std::string trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t\r"), b = s.find_last_not_of(" \t\r");
  return a == std::string::npos ? std::string() : s.substr(a, b - a + 1);
}

}  // namespace

std::string glsl_es_300(const std::string& source) {
  // What ES 3.00 lacks and the renderer's shaders never use: refused rather than mistranslated.
  static const std::regex unsupported(
      R"(\b(double|dvec[234]|dmat[234])\b|\bbinding\s*=|#\s*extension)");
  std::smatch found;
  if (std::regex_search(source, found, unsupported))
    throw Error("glsl_es_300: the shader uses \"" + found.str() + "\", which GLSL ES 3.00 lacks");

  std::istringstream in(source);
  std::string first;
  std::getline(in, first);
  const std::string line = trim(first);
  if (line.rfind("#version", 0) != 0) return std::string(kEsPreamble) + "#line 1 0\n" + source;
  static const std::regex version(R"(#\s*version\s+450(\s+core)?\s*)");
  if (!std::regex_match(line, version))
    throw Error("glsl_es_300: expected \"#version 450 core\" as the first line, got \"" + line +
                "\"");
  std::string rest((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return std::string(kEsPreamble) + "#line 2 0\n" + rest;
}

}  // namespace raywarp::gl
