# Writes OUT, a C++ file that holds every file under DIR as a string, looked up by its path
# relative to DIR, in the function FUNCTION (namespace NAMESPACE, default raywarp) that HEADER
# declares. Used for the GLSL shaders (shaders/ -> gl/shader_sources.h, namespace raywarp::gl;
# gl::ShaderFiles numbers them by their sorted names), the browser viewer (viewer/ ->
# cli/viewer_files.h) and the engine templates (engines/ -> cli/engine_templates.h), so that an
# installed raywarp needs no source tree.
if(NOT DEFINED NAMESPACE)
  set(NAMESPACE raywarp)
endif()
file(GLOB_RECURSE files RELATIVE ${DIR} ${DIR}/*)
list(SORT files)
get_filename_component(folder ${DIR} NAME)
set(body "// Generated from ${folder}/ by scripts/embed_files.cmake. Do not edit.\n")
string(APPEND body "#include \"${HEADER}\"\n\nnamespace ${NAMESPACE} {\n")
string(APPEND body "const std::map<std::string, std::string>& ${FUNCTION}() {\n")
string(APPEND body "  static const std::map<std::string, std::string> files = {\n")
foreach(name ${files})
  file(READ ${DIR}/${name} text)
  string(FIND "${text}" ")raywarp_file\"" delimiter)
  if(NOT delimiter EQUAL -1)
    message(FATAL_ERROR "${folder}/${name} holds the raw string delimiter )raywarp_file\"")
  endif()
  # A raw string literal is split every 16000 characters (compilers limit one literal's length).
  string(LENGTH "${text}" length)
  string(APPEND body "    {\"${name}\", std::string(")
  set(offset 0)
  while(offset LESS length)
    string(SUBSTRING "${text}" ${offset} 16000 piece)
    string(APPEND body "R\"raywarp_file(${piece})raywarp_file\"\n")
    math(EXPR offset "${offset} + 16000")
  endwhile()
  if(length EQUAL 0)
    string(APPEND body "\"\"")
  endif()
  string(APPEND body ")},\n")
endforeach()
string(APPEND body "  };\n  return files;\n}\n}  // namespace ${NAMESPACE}\n")
file(WRITE ${OUT}.tmp "${body}")
file(RENAME ${OUT}.tmp ${OUT})
