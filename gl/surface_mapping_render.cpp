#include "gl/surface_mapping_render.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>

#include "base/error.h"
#include "gl/gl_api.h"
#include "gl/shader_sources.h"

namespace raywarp::gl {

namespace {

constexpr const char* kVertexFile = "surface_mapping.vert.glsl";
constexpr const char* kReadbackFile = "surface_mapping_readback.frag.glsl";

// Eq. 9 per vertex; the arithmetic follows frame_of in library/surface_mapping.cpp line by line.
const char* const kVertexSource = R"(// Mosegaard & Sorensen 2006 eq. 9: library/surface_mapping.h.
#include "camera.glsl"
uniform sampler2D u_nodes;       // texel 2i: surface node i's position, 2i + 1: its unit normal
uniform isampler2D u_triangles;  // texel t: the surface nodes of triangle t
uniform bool u_interpolated;     // eq. 8's frame (curvature correction), else eq. 6's
layout(location = 0) in vec3 a_binding;  // (triangle or -1, u, v)
layout(location = 1) in vec3 a_offset;   // (o.T, o.N, o.B)
layout(location = 2) in vec3 a_normal;   // the rest vertex normal in the same frame
out vec3 v_position;
out vec3 v_normal;

const int kWidth = RAYWARP_TEXTURE_WIDTH;
ivec2 texel(int i) { return ivec2(i % kWidth, i / kWidth); }
vec3 node(int i) { return texelFetch(u_nodes, texel(i), 0).xyz; }

void map_vertex(out vec3 position, out vec3 normal) {
  if (a_binding.x < 0.0) {  // not bound: stays put (offset: the rest position)
    position = a_offset;
    normal = a_normal;
    return;
  }
  ivec3 n = texelFetch(u_triangles, texel(int(a_binding.x)), 0).xyz;
  vec3 p1 = node(2 * n.x), p2 = node(2 * n.y), p3 = node(2 * n.z);
  float u = a_binding.y, v = a_binding.z;
  vec3 e1 = p2 - p1, e2 = p3 - p1;
  vec3 r = p1 + u * e1 + v * e2;
  vec3 T = normalize(e1);
  vec3 N = normalize(cross(T, normalize(e2)));
  vec3 B = cross(N, T);
  if (u_interpolated) {
    vec3 nc = (1.0 - u - v) * node(2 * n.x + 1) + u * node(2 * n.y + 1) + v * node(2 * n.z + 1);
    vec3 bc = cross(nc, T);
    float len = length(nc), b_len = length(bc);
    if (b_len > 1e-6 * len) {
      N = nc / len;
      B = bc / b_len;
      T = cross(B, N);
    }
  }
  position = r + a_offset.x * T + a_offset.y * N + a_offset.z * B;
  normal = a_normal.x * T + a_normal.y * N + a_normal.z * B;
}

void main() {
  map_vertex(v_position, v_normal);
#ifdef RAYWARP_READBACK
  gl_Position = vec4((vec2(texel(gl_VertexID)) + 0.5) / u_viewport * 2.0 - 1.0, 0.0, 1.0);
#else
  gl_Position = u_view_proj * vec4(v_position, 1.0);
#endif
}
)";

const char* const kReadbackSource = R"(// The mapped vertices, one point each, in float.
in vec3 v_position;
in vec3 v_normal;
layout(location = 0) out vec4 out_position;
layout(location = 1) out vec4 out_normal;

void main() {
  out_position = vec4(v_position, 1.0);
  out_normal = vec4(v_normal, 0.0);
}
)";

// The embedded shaders/*.glsl and the two files above.
const ShaderFiles& shader_files() {
  static const ShaderFiles files = [] {
    std::map<std::string, std::string> texts = embedded_shaders();
    texts[kVertexFile] = kVertexSource;
    texts[kReadbackFile] = kReadbackSource;
    return ShaderFiles(texts);
  }();
  return files;
}

int rows_for(long texels) {
  return static_cast<int>(std::max<long>(1, (texels + SurfaceMappingRenderer::kTextureWidth - 1) /
                                                SurfaceMappingRenderer::kTextureWidth));
}

GLuint make_texture() {
  GLuint t = 0;
  glGenTextures(1, &t);
  glBindTexture(GL_TEXTURE_2D, t);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  return t;
}

}  // namespace

const std::string& surface_mapping_vertex_glsl() {
  static const std::string text = kVertexSource;
  return text;
}

struct SurfaceMappingRenderer::Impl {
  GLuint draw = 0, readback = 0;  // programs
  GLuint vao = 0, points_vao = 0, vbo = 0, ebo = 0, points_ebo = 0;
  GLuint nodes_tex = 0, triangles_tex = 0;
  std::size_t binding_bytes = 0, node_bytes = 0;  // gpu_bytes()
  GLsizei indices = 0, vertices = 0;
  bool interpolated = false;
  int node_count = 0;
  std::vector<NodeTriangle> triangles;  // global node numbers, for the normals
  std::vector<int> surface;             // surface node k -> global node number
  bool has_nodes = false;
  GLuint fbo = 0, colour_tex = 0, depth_tex = 0, zbuffer = 0;
  int fbo_w = 0, fbo_h = 0;

  void delete_framebuffer() {
    if (!fbo) return;
    glDeleteFramebuffers(1, &fbo);
    GLuint t[3] = {colour_tex, depth_tex, zbuffer};
    glDeleteTextures(3, t);
    fbo = 0;
  }

  // As gl::Renderer's: sRGB colour, linear eye depth (R32F) and a float z-buffer.
  void ensure_framebuffer(int w, int h) {
    if (fbo && w == fbo_w && h == fbo_h) return;
    delete_framebuffer();
    auto tex2d = [&](GLenum internal, GLenum format, GLenum type) {
      GLuint t = make_texture();
      glTexImage2D(GL_TEXTURE_2D, 0, internal, w, h, 0, format, type, nullptr);
      return t;
    };
    colour_tex = tex2d(GL_RGBA8, GL_RGBA, GL_UNSIGNED_BYTE);
    depth_tex = tex2d(GL_R32F, GL_RED, GL_FLOAT);
    zbuffer = tex2d(GL_DEPTH_COMPONENT32F, GL_DEPTH_COMPONENT, GL_FLOAT);
    glGenFramebuffers(1, &fbo);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, colour_tex, 0);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT1, GL_TEXTURE_2D, depth_tex, 0);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, zbuffer, 0);
    GLenum buffers[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    glDrawBuffers(2, buffers);
    if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
      throw Error("OpenGL: cannot make a " + std::to_string(w) + "x" + std::to_string(h) +
                  " framebuffer");
    fbo_w = w;
    fbo_h = h;
  }

  void bind_textures(GLuint program) const {
    glUseProgram(program);
    glUniform1i(glGetUniformLocation(program, "u_nodes"), 0);
    glUniform1i(glGetUniformLocation(program, "u_triangles"), 1);
    glUniform1i(glGetUniformLocation(program, "u_interpolated"), interpolated);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, nodes_tex);
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_2D, triangles_tex);
    glActiveTexture(GL_TEXTURE0);
  }

  void check_ready() const {
    if (!vertices) throw Error("SurfaceMappingRenderer: no binding (set_binding)");
    if (!has_nodes) throw Error("SurfaceMappingRenderer: no node positions (set_nodes)");
  }
};

SurfaceMappingRenderer::SurfaceMappingRenderer() : impl_(std::make_unique<Impl>()) {
  const std::string width = "#define RAYWARP_TEXTURE_WIDTH " + std::to_string(kTextureWidth) + "\n";
  impl_->draw = link_program(
      shader_files(), kVertexFile, "raster.frag.glsl",
      width + "#define RAYWARP_MAX_BOXES " + std::to_string(Renderer::kMaxBoxes) + "\n");
  try {
    impl_->readback = link_program(shader_files(), kVertexFile, kReadbackFile,
                                   width + "#define RAYWARP_READBACK 1\n");
  } catch (...) {
    glDeleteProgram(impl_->draw);
    throw;
  }
  glGenVertexArrays(1, &impl_->vao);
  glGenVertexArrays(1, &impl_->points_vao);
  glGenBuffers(1, &impl_->vbo);
  glGenBuffers(1, &impl_->ebo);
  glGenBuffers(1, &impl_->points_ebo);
  impl_->nodes_tex = make_texture();
  impl_->triangles_tex = make_texture();
}

SurfaceMappingRenderer::~SurfaceMappingRenderer() {
  auto& m = *impl_;
  glDeleteProgram(m.draw);
  glDeleteProgram(m.readback);
  GLuint vaos[2] = {m.vao, m.points_vao};
  glDeleteVertexArrays(2, vaos);
  GLuint buffers[3] = {m.vbo, m.ebo, m.points_ebo};
  glDeleteBuffers(3, buffers);
  GLuint textures[2] = {m.nodes_tex, m.triangles_tex};
  glDeleteTextures(2, textures);
  m.delete_framebuffer();
}

void SurfaceMappingRenderer::set_binding(const SurfaceBinding& binding, const Mesh& mesh) {
  auto& m = *impl_;
  const long n = static_cast<long>(binding.size());
  if (mesh.V.rows() != n)
    throw Error("SurfaceMappingRenderer: the mesh has " + std::to_string(mesh.V.rows()) +
                " vertices, the binding " + std::to_string(n));
  if (binding.triangles.size() >= (size_t(1) << 24))
    throw Error("SurfaceMappingRenderer: " + std::to_string(binding.triangles.size()) +
                " coarse triangles; a float attribute names at most 2^24");
  // The surface nodes, in ascending global order, and the triangles in their numbers.
  std::vector<int> local(binding.node_count, -1);
  m.surface.clear();
  for (const NodeTriangle& t : binding.triangles)
    for (int c : t) local[c] = 0;
  for (int i = 0; i < binding.node_count; ++i)
    if (local[i] == 0) {
      local[i] = static_cast<int>(m.surface.size());
      m.surface.push_back(i);
    }
  std::vector<GLint> tri(
      static_cast<size_t>(kTextureWidth) * rows_for(binding.triangles.size()) * 4, 0);
  for (size_t t = 0; t < binding.triangles.size(); ++t)
    for (int c = 0; c < 3; ++c) tri[4 * t + c] = local[binding.triangles[t][c]];
  glBindTexture(GL_TEXTURE_2D, m.triangles_tex);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32I, kTextureWidth, rows_for(binding.triangles.size()), 0,
               GL_RGBA_INTEGER, GL_INT, tri.data());

  std::vector<float> attributes(static_cast<size_t>(n) * 9);
  for (long i = 0; i < n; ++i) {
    float* a = &attributes[9 * i];
    a[0] = static_cast<float>(binding.triangle[i]);
    a[1] = static_cast<float>(binding.weights[i].x());
    a[2] = static_cast<float>(binding.weights[i].y());
    for (int c = 0; c < 3; ++c) {
      a[3 + c] = static_cast<float>(binding.offset[i][c]);
      a[6 + c] = static_cast<float>(binding.normal[i][c]);
    }
  }
  std::vector<GLuint> points(n);
  std::iota(points.begin(), points.end(), 0u);
  glBindBuffer(GL_ARRAY_BUFFER, m.vbo);
  glBufferData(GL_ARRAY_BUFFER, attributes.size() * sizeof(float), attributes.data(),
               GL_STATIC_DRAW);
  for (GLuint vao : {m.vao, m.points_vao}) {
    glBindVertexArray(vao);
    glBindBuffer(GL_ARRAY_BUFFER, m.vbo);
    for (GLuint a = 0; a < 3; ++a) {
      glVertexAttribPointer(a, 3, GL_FLOAT, GL_FALSE, 9 * sizeof(float),
                            reinterpret_cast<const void*>(3 * a * sizeof(float)));
      glEnableVertexAttribArray(a);
    }
  }
  glBindVertexArray(m.vao);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, m.ebo);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, mesh.F.size() * sizeof(int), mesh.F.data(), GL_STATIC_DRAW);
  glBindVertexArray(m.points_vao);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, m.points_ebo);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, points.size() * sizeof(GLuint), points.data(),
               GL_STATIC_DRAW);
  glBindVertexArray(0);
  if (glGetError() != GL_NO_ERROR)
    throw Error("OpenGL: cannot upload the surface binding of " + std::to_string(n) + " vertices");
  m.indices = static_cast<GLsizei>(mesh.F.size());
  m.vertices = static_cast<GLsizei>(n);
  m.binding_bytes = tri.size() * sizeof(GLint) + attributes.size() * sizeof(float) +
                    static_cast<std::size_t>(mesh.F.size()) * sizeof(int) +
                    points.size() * sizeof(GLuint);
  m.interpolated = binding.basis == SurfaceBasis::Interpolated;
  m.node_count = binding.node_count;
  m.triangles = binding.triangles;
  m.has_nodes = false;
}

void SurfaceMappingRenderer::set_nodes(const std::vector<Eigen::Vector3d>& deformed_nodes) {
  auto& m = *impl_;
  if (static_cast<long>(deformed_nodes.size()) != m.node_count)
    throw Error("SurfaceMappingRenderer: " + std::to_string(deformed_nodes.size()) +
                " nodes, the binding was made for " + std::to_string(m.node_count));
  const std::vector<Eigen::Vector3d> normals =
      m.interpolated ? node_normals(deformed_nodes, m.triangles) : std::vector<Eigen::Vector3d>{};
  const int rows = rows_for(2 * static_cast<long>(m.surface.size()));
  std::vector<float> texels(static_cast<size_t>(kTextureWidth) * rows * 4, 0.0f);
  for (size_t k = 0; k < m.surface.size(); ++k) {
    const Eigen::Vector3d& p = deformed_nodes[m.surface[k]];
    for (int c = 0; c < 3; ++c) {
      texels[8 * k + c] = static_cast<float>(p[c]);
      if (m.interpolated) texels[8 * k + 4 + c] = static_cast<float>(normals[m.surface[k]][c]);
    }
  }
  glBindTexture(GL_TEXTURE_2D, m.nodes_tex);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, kTextureWidth, rows, 0, GL_RGBA, GL_FLOAT,
               texels.data());
  if (glGetError() != GL_NO_ERROR)
    throw Error("OpenGL: cannot upload " + std::to_string(m.surface.size()) + " surface nodes");
  m.has_nodes = true;
  m.node_bytes = texels.size() * sizeof(float);
}

std::size_t SurfaceMappingRenderer::gpu_bytes() const {
  return impl_->binding_bytes + impl_->node_bytes;
}

int SurfaceMappingRenderer::surface_nodes() const {
  return static_cast<int>(impl_->surface.size());
}

Image SurfaceMappingRenderer::render(const Camera& camera, int width, int height,
                                     const RenderSettings& settings, FrameStats* stats) {
  auto& m = *impl_;
  m.check_ready();
  m.ensure_framebuffer(width, height);
  glFinish();
  const auto start = std::chrono::steady_clock::now();
  glBindFramebuffer(GL_FRAMEBUFFER, m.fbo);
  glViewport(0, 0, width, height);
  auto encode = [](double c) { return float(srgb_encode(c)); };
  const float background[4] = {encode(settings.background.x()), encode(settings.background.y()),
                               encode(settings.background.z()), 1.0f};
  const float far_depth[4] = {std::numeric_limits<float>::infinity(), 0, 0, 0};
  const float one = 1.0f;
  glClearBufferfv(GL_COLOR, 0, background);
  glClearBufferfv(GL_COLOR, 1, far_depth);
  glClearBufferfv(GL_DEPTH, 0, &one);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDisable(GL_CULL_FACE);

  m.bind_textures(m.draw);
  auto loc = [&](const char* name) { return glGetUniformLocation(m.draw, name); };
  auto vec3 = [&](const char* name, const Eigen::Vector3d& v) {
    glUniform3f(loc(name), float(v.x()), float(v.y()), float(v.z()));
  };
  const Eigen::Matrix4f view_proj =
      (camera.projection_matrix(double(width) / height) * camera.view()).cast<float>();
  glUniformMatrix4fv(loc("u_view_proj"), 1, GL_FALSE, view_proj.data());
  vec3("u_eye", camera.eye);
  vec3("u_view_dir", camera.view_direction());
  glUniform2f(loc("u_viewport"), float(width), float(height));
  glUniform1i(loc("u_orthographic"), camera.projection == Camera::Projection::Orthographic);
  vec3("u_albedo", settings.colour);
  vec3("u_inside_colour", settings.inside_colour);
  glUniform1i(loc("u_two_sided"), 0);
  glUniform1i(loc("u_box_count"), 0);
  glBindVertexArray(m.vao);
  glDrawElements(GL_TRIANGLES, m.indices, GL_UNSIGNED_INT, nullptr);
  glBindVertexArray(0);
  glFinish();
  const auto stop = std::chrono::steady_clock::now();

  long nonfinite = 0;
  Image image = read_back_image(width, height, background, &nonfinite);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  if (stats) {
    stats->milliseconds = std::chrono::duration<double, std::milli>(stop - start).count();
    stats->nonfinite_pixels = nonfinite;
  }
  return image;
}

SurfaceMappingRenderer::Mapped SurfaceMappingRenderer::mapped_vertices() {
  auto& m = *impl_;
  m.check_ready();
  const int rows = rows_for(m.vertices);
  GLuint fbo = 0, tex[2] = {0, 0};
  for (GLuint& t : tex) {
    t = make_texture();
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, kTextureWidth, rows, 0, GL_RGBA, GL_FLOAT, nullptr);
  }
  glGenFramebuffers(1, &fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, tex[0], 0);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT1, GL_TEXTURE_2D, tex[1], 0);
  GLenum buffers[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
  glDrawBuffers(2, buffers);
  Mapped out;
  try {
    if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
      throw Error("OpenGL: cannot make a " + std::to_string(kTextureWidth) + "x" +
                  std::to_string(rows) + " float framebuffer");
    glViewport(0, 0, kTextureWidth, rows);
    const float nan4[4] = {std::numeric_limits<float>::quiet_NaN(),
                           std::numeric_limits<float>::quiet_NaN(),
                           std::numeric_limits<float>::quiet_NaN(), 0.0f};
    glClearBufferfv(GL_COLOR, 0, nan4);  // a vertex the draw misses reads back as NaN
    glClearBufferfv(GL_COLOR, 1, nan4);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_CULL_FACE);
    m.bind_textures(m.readback);
    glUniform2f(glGetUniformLocation(m.readback, "u_viewport"), float(kTextureWidth), float(rows));
    glBindVertexArray(m.points_vao);
    glDrawElements(GL_POINTS, m.vertices, GL_UNSIGNED_INT, nullptr);
    glBindVertexArray(0);
    std::vector<float> texels(static_cast<size_t>(kTextureWidth) * rows * 4);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    for (int a = 0; a < 2; ++a) {
      glReadBuffer(GL_COLOR_ATTACHMENT0 + a);
      glReadPixels(0, 0, kTextureWidth, rows, GL_RGBA, GL_FLOAT, texels.data());
      auto& to = a == 0 ? out.positions : out.normals;
      to.resize(m.vertices);
      for (GLsizei i = 0; i < m.vertices; ++i)
        to[i] = Eigen::Vector3f(texels[4 * i], texels[4 * i + 1], texels[4 * i + 2]);
    }
  } catch (...) {
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glDeleteFramebuffers(1, &fbo);
    glDeleteTextures(2, tex);
    throw;
  }
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glDeleteFramebuffers(1, &fbo);
  glDeleteTextures(2, tex);
  return out;
}

}  // namespace raywarp::gl
