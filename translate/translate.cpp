#include "translate/translate.h"

#include <glslang/Public/ResourceLimits.h>
#include <glslang/Public/ShaderLang.h>
#include <glslang/SPIRV/GlslangToSpv.h>
#include <spirv_cross/spirv_cross_c.h>

#include <algorithm>
#include <mutex>
#include <regex>
#include <set>
#include <sstream>

#include "base/error.h"

namespace raywarp::translate {

namespace {

// glslang keeps process-wide tables: initialised once, and one compile at a time.
std::mutex& glslang_mutex() {
  static std::mutex m;
  return m;
}

void initialise_glslang() {
  static std::once_flag once;
  std::call_once(once, [] { glslang::InitializeProcess(); });
}

EShLanguage language(Stage stage) {
  return stage == Stage::Vertex ? EShLangVertex : EShLangFragment;
}

Spirv compile(const std::string& text, Stage stage, bool hlsl, const std::string& entry,
              const std::string& where) {
  initialise_glslang();
  std::lock_guard<std::mutex> lock(glslang_mutex());
  const EShLanguage lang = language(stage);
  glslang::TShader shader(lang);
  const char* strings[] = {text.c_str()};
  const char* names[] = {where.c_str()};
  shader.setStringsWithLengthsAndNames(strings, nullptr, names, 1);
  shader.setEntryPoint(entry.c_str());
  shader.setSourceEntryPoint(entry.c_str());
  shader.setAutoMapBindings(true);
  shader.setAutoMapLocations(true);
  EShMessages messages = static_cast<EShMessages>(EShMsgSpvRules | EShMsgDefault);
  if (hlsl) {
    shader.setEnvInput(glslang::EShSourceHlsl, lang, glslang::EShClientVulkan, 100);
    shader.setEnvClient(glslang::EShClientVulkan, glslang::EShTargetVulkan_1_0);
    messages = static_cast<EShMessages>(messages | EShMsgReadHlsl | EShMsgVulkanRules);
  } else {
    shader.setEnvInput(glslang::EShSourceGlsl, lang, glslang::EShClientOpenGL, 450);
    shader.setEnvClient(glslang::EShClientOpenGL, glslang::EShTargetOpenGL_450);
  }
  shader.setEnvTarget(glslang::EShTargetSpv, glslang::EShTargetSpv_1_0);
  if (!shader.parse(GetDefaultResources(), hlsl ? 100 : 450, false, messages))
    throw Error(where + ": does not compile (glslang" + (hlsl ? ", HLSL" : ", GLSL") + "):\n" +
                shader.getInfoLog());
  glslang::TProgram program;
  program.addShader(&shader);
  if (!program.link(messages) || !program.mapIO())
    throw Error(where + ": does not link (glslang):\n" + program.getInfoLog());
  Spirv spirv;
  spv::SpvBuildLogger logger;
  glslang::SpvOptions options;
  options.generateDebugInfo = false;
  options.disableOptimizer = !hlsl;  // HLSL needs spirv-opt's legalization (opaque struct members)
  glslang::GlslangToSpv(*program.getIntermediate(lang), spirv, &logger, &options);
  const std::string log = logger.getAllMessages();
  if (spirv.empty()) throw Error(where + ": no SPIR-V from glslang:\n" + log);
  return spirv;
}

// A SPIRV-Cross context whose errors become Error.
class Cross {
 public:
  Cross() {
    if (spvc_context_create(&context_) != SPVC_SUCCESS)
      throw Error("SPIRV-Cross: cannot create a context");
    spvc_context_set_error_callback(
        context_,
        [](void* user, const char* message) {
          static_cast<std::string*>(user)->append(message).append("\n");
        },
        &errors_);
  }
  ~Cross() { spvc_context_destroy(context_); }
  Cross(const Cross&) = delete;
  Cross& operator=(const Cross&) = delete;

  spvc_compiler compiler(const Spirv& spirv, spvc_backend backend) {
    spvc_parsed_ir ir = nullptr;
    check(spvc_context_parse_spirv(context_, spirv.data(), spirv.size(), &ir), "parse");
    spvc_compiler c = nullptr;
    check(spvc_context_create_compiler(context_, backend, ir, SPVC_CAPTURE_MODE_TAKE_OWNERSHIP, &c),
          "create a compiler");
    return c;
  }
  void check(spvc_result r, const char* what) const {
    if (r != SPVC_SUCCESS) throw Error(std::string("SPIRV-Cross: cannot ") + what + ": " + errors_);
  }

 private:
  spvc_context context_ = nullptr;
  std::string errors_;
};

// The resources of `type` (id, name).
std::vector<spvc_reflected_resource> resources(Cross& cross, spvc_compiler c,
                                               spvc_resource_type type) {
  spvc_resources res = nullptr;
  cross.check(spvc_compiler_create_shader_resources(c, &res), "reflect");
  const spvc_reflected_resource* list = nullptr;
  size_t n = 0;
  cross.check(spvc_resources_get_resource_list_for_type(res, type, &list, &n), "reflect");
  return {list, list + n};
}

void unset_bindings(Cross& cross, spvc_compiler c) {
  for (spvc_resource_type type :
       {SPVC_RESOURCE_TYPE_SAMPLED_IMAGE, SPVC_RESOURCE_TYPE_SEPARATE_IMAGE,
        SPVC_RESOURCE_TYPE_SEPARATE_SAMPLERS, SPVC_RESOURCE_TYPE_UNIFORM_BUFFER})
    for (const spvc_reflected_resource& r : resources(cross, c, type)) {
      spvc_compiler_unset_decoration(c, r.id, SpvDecorationBinding);
      spvc_compiler_unset_decoration(c, r.id, SpvDecorationDescriptorSet);
    }
}

std::string compile_text(Cross& cross, spvc_compiler c) {
  const char* text = nullptr;
  cross.check(spvc_compiler_compile(c, &text), "translate");
  return text;
}

std::string replace_word(const std::string& text, const std::string& from, const std::string& to) {
  return std::regex_replace(text, std::regex("\\b" + from + "\\b"), to);
}

}  // namespace

Spirv glsl_to_spirv(const std::string& glsl, Stage stage, const std::string& where) {
  return compile(glsl, stage, false, "main", where);
}

Spirv hlsl_to_spirv(const std::string& hlsl, Stage stage, const std::string& entry,
                    const std::string& where) {
  return compile(hlsl, stage, true, entry, where);
}

std::string spirv_to_hlsl(const Spirv& spirv, const HlslOptions& options) {
  Cross cross;
  spvc_compiler c = cross.compiler(spirv, SPVC_BACKEND_HLSL);
  spvc_compiler_options opts = nullptr;
  cross.check(spvc_compiler_create_compiler_options(c, &opts), "set options");
  spvc_compiler_options_set_uint(opts, SPVC_COMPILER_OPTION_HLSL_SHADER_MODEL,
                                 static_cast<unsigned>(options.shader_model));
  cross.check(spvc_compiler_install_compiler_options(c, opts), "set options");
  unset_bindings(cross, c);
  std::string text = compile_text(cross, c);
  for (const auto& [texture, sampler] : options.sampler_names)
    text = replace_word(text, "_" + texture + "_sampler", sampler);
  return text;
}

std::string spirv_to_glsl(const Spirv& spirv) {
  Cross cross;
  spvc_compiler c = cross.compiler(spirv, SPVC_BACKEND_GLSL);
  spvc_compiler_options opts = nullptr;
  cross.check(spvc_compiler_create_compiler_options(c, &opts), "set options");
  spvc_compiler_options_set_uint(opts, SPVC_COMPILER_OPTION_GLSL_VERSION, 450);
  spvc_compiler_options_set_bool(opts, SPVC_COMPILER_OPTION_GLSL_ES, SPVC_FALSE);
  spvc_compiler_options_set_bool(
      opts, SPVC_COMPILER_OPTION_GLSL_EMIT_UNIFORM_BUFFER_AS_PLAIN_UNIFORMS, SPVC_TRUE);
  cross.check(spvc_compiler_install_compiler_options(c, opts), "set options");
  spvc_variable_id dummy = 0;  // for the images read by texel (Load) with no sampler
  cross.check(spvc_compiler_build_dummy_sampler_for_combined_images(c, &dummy), "combine samplers");
  cross.check(spvc_compiler_build_combined_image_samplers(c), "combine samplers");
  const spvc_combined_image_sampler* combined = nullptr;
  size_t n = 0;
  cross.check(spvc_compiler_get_combined_image_samplers(c, &combined, &n), "combine samplers");
  // Each combined sampler is named after its image. An image read both with a sampler and without
  // one (textureSize, texelFetch: the dummy sampler) gets two; the dummy one is then merged into
  // the other after translation, so that one sampler uniform reads the image.
  std::set<spvc_variable_id> sampled;
  for (size_t i = 0; i < n; ++i)
    if (combined[i].sampler_id != dummy) sampled.insert(combined[i].image_id);
  std::vector<std::pair<std::string, std::string>> merged;  // (dummy's name, image's name)
  for (size_t i = 0; i < n; ++i) {
    const std::string image = spvc_compiler_get_name(c, combined[i].image_id);
    if (combined[i].sampler_id == dummy && sampled.count(combined[i].image_id)) {
      merged.emplace_back("raywarp_unsampled_" + image, image);
      spvc_compiler_set_name(c, combined[i].combined_id, merged.back().first.c_str());
    } else {
      spvc_compiler_set_name(c, combined[i].combined_id, image.c_str());
    }
  }
  // Each uniform buffer's variable gets a name of ours, so that its members can be made loose.
  // Its row-major matrices (HLSL's) are uploaded column-major once loose (glUniformMatrix*fv), so
  // every use of one reads transpose(NAME).
  std::vector<std::string> blocks, row_major;
  for (const spvc_reflected_resource& r : resources(cross, c, SPVC_RESOURCE_TYPE_UNIFORM_BUFFER)) {
    blocks.push_back("raywarp_loose_block_" + std::to_string(blocks.size()));
    spvc_compiler_set_name(c, r.id, blocks.back().c_str());
    const spvc_type type = spvc_compiler_get_type_handle(c, r.base_type_id);
    for (unsigned i = 0; i < spvc_type_get_num_member_types(type); ++i)
      if (spvc_compiler_has_member_decoration(c, r.base_type_id, i, SpvDecorationRowMajor))
        row_major.push_back(spvc_compiler_get_member_name(c, r.base_type_id, i));
  }
  unset_bindings(cross, c);
  const SpvExecutionMode* modes = nullptr;
  size_t mode_count = 0;
  cross.check(spvc_compiler_get_execution_modes(c, &modes, &mode_count), "reflect");
  const bool upper_left =
      spvc_compiler_get_execution_model(c) == SpvExecutionModelFragment &&
      std::find(modes, modes + mode_count, SpvExecutionModeOriginUpperLeft) != modes + mode_count;
  std::string text = compile_text(cross, c);
  // SPIRV-Cross leaves out the origin of gl_FragCoord for OpenGL; HLSL's (and Vulkan's) pixel
  // rows count from the top.
  if (upper_left && text.find("gl_FragCoord") != std::string::npos)
    text.insert(text.find('\n') + 1, "layout(origin_upper_left) in vec4 gl_FragCoord;\n");
  for (const auto& [unsampled, image] : merged) {
    text = std::regex_replace(text, std::regex("uniform \\w+ " + unsampled + ";\\n"), "");
    text = replace_word(text, unsampled, image);
  }
  std::set<std::string> loose;
  for (const std::string& block : blocks) {
    // `struct T\n{\n    MEMBERS\n};\n\nuniform T block;` -> `uniform MEMBER;` lines.
    const std::regex decl("(^|\\n)uniform (\\w+) " + block + ";\\n");
    std::smatch m;
    if (!std::regex_search(text, m, decl))
      throw Error("SPIRV-Cross: no plain uniform " + block + " in its GLSL");
    const std::string type = m[2];
    const size_t decl_at = static_cast<size_t>(m.position(0)) + m[1].length();
    const size_t decl_end = static_cast<size_t>(m.position(0) + m.length(0));
    const std::string head = "struct " + type + "\n{\n";
    const size_t s = text.find(head);
    const size_t e = s == std::string::npos ? s : text.find("\n};\n", s);
    if (e == std::string::npos || e > decl_at)
      throw Error("SPIRV-Cross: no struct " + type + " before the uniform " + block);
    std::istringstream members(text.substr(s + head.size(), e + 1 - (s + head.size())));
    std::string line, uniforms;
    const std::regex member("^\\s*(\\w+) (\\w+)(\\[\\d+\\])?;$");
    while (std::getline(members, line)) {
      std::smatch mm;
      if (!std::regex_match(line, mm, member))
        throw Error("SPIRV-Cross: member `" + line + "` of " + type + " cannot be made loose");
      if (!loose.insert(mm[2]).second) throw Error("uniform " + std::string(mm[2]) + " twice");
      uniforms += "uniform " + line.substr(line.find_first_not_of(' ')) + "\n";
    }
    text = text.substr(0, s) + text.substr(e + 4, decl_at - (e + 4)) + uniforms +
           text.substr(decl_end);
    text = std::regex_replace(text, std::regex("\\b" + block + "\\."), "");
  }
  for (const std::string& name : row_major) {
    const std::regex declaration("\\nuniform (mat[234]) " + name + ";\\n");
    std::smatch m;
    if (!std::regex_search(text, m, declaration))
      throw Error("SPIRV-Cross: the row-major matrix " + name + " is no loose uniform");
    const size_t body = static_cast<size_t>(m.position(0) + m.length(0));
    text = text.substr(0, body) + std::regex_replace(text.substr(body),
                                                     std::regex("\\b" + name + "\\b"),
                                                     "transpose(" + name + ")");
  }
  return text;
}

}  // namespace raywarp::translate
