#include "gl/tet_render.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <string>

#include "base/error.h"
#include "gl/gl_api.h"
#include "gl/shader_sources.h"
#include "library/tet_mesh.h"

namespace raywarp::gl {

namespace {

constexpr const char* kQuadVertexFile = "tet_quad.vert.glsl";
constexpr const char* kGeometryFile = "tet_geometry.frag.glsl";
constexpr const char* kFaceVertexFile = "tet_face.vert.glsl";
constexpr const char* kEntryFile = "tet_entry.frag.glsl";
constexpr const char* kWalkFile = "tet_walk.frag.glsl";
constexpr const char* kResolveFile = "tet_resolve.frag.glsl";

// How far behind t_in an exit plane may lie and still count, relative to (mesh diagonal + |t_in|):
// the CPU mirror's 1e-9 (verify/tet_walk.cpp) is about 1e7 double ulps; in float a plane's λ
// carries a few ulps of (|o| + diagonal) divided by r · n, so 1e-5 (about 170 float ulps) keeps
// faces down to r · n ~ 0.01. A larger tolerance only admits exit faces whose exact λ is behind
// t_in, which happens only where rounding put the ray into a tetrahedron it grazes.
constexpr float kBehindTolerance = 1e-5f;
// A tetrahedron is degenerate on the GPU when |6 V| <= this fraction of its longest edge cubed:
// the float triple product carries a few ulps (1.2e-7) of that scale, so 1e-6 (the CPU's is
// 1e-10) is the least that rounding cannot make look solid.
constexpr float kDegenerateRelative = 1e-6f;
// The longest a segment's table lookup is cut into (the CPU's lookup allows 1e6 pieces; a
// segment that long is opaque far sooner).
constexpr int kMaxLookupPieces = 4096;
// Per-pixel walk state, channel w of state B: sections * 4 + flag.
constexpr int kFlagActive = 0, kFlagDone = 1, kFlagCapped = 2;

// The walk's pieces are shaders/tet_*.glsl, embedded with the others.
const ShaderFiles& shader_files() { return ShaderFiles::embedded(); }

int rows_for(long count) {
  return static_cast<int>(
      std::max<long>(1, (count + TetRenderer::kTextureWidth - 1) / TetRenderer::kTextureWidth));
}

GLuint make_texture_2d(GLenum internal, int w, int h, GLenum format, GLenum type,
                       const void* data) {
  GLuint t = 0;
  glGenTextures(1, &t);
  glBindTexture(GL_TEXTURE_2D, t);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexImage2D(GL_TEXTURE_2D, 0, internal, w, h, 0, format, type, data);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  return t;
}

void delete_texture(GLuint& t) {
  if (t) glDeleteTextures(1, &t);
  t = 0;
}

// A framebuffer of the given colour attachments (and depth, when given), all drawn.
GLuint make_framebuffer(const std::vector<GLuint>& colour, GLuint depth, const std::string& what) {
  GLuint fbo = 0;
  glGenFramebuffers(1, &fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo);
  std::vector<GLenum> buffers;
  for (size_t i = 0; i < colour.size(); ++i) {
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0 + static_cast<GLenum>(i),
                           GL_TEXTURE_2D, colour[i], 0);
    buffers.push_back(GL_COLOR_ATTACHMENT0 + static_cast<GLenum>(i));
  }
  if (depth) glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, depth, 0);
  glDrawBuffers(static_cast<GLsizei>(buffers.size()), buffers.data());
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glDeleteFramebuffers(1, &fbo);
    throw Error("OpenGL: cannot make the " + what + " framebuffer");
  }
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  return fbo;
}

void delete_framebuffer(GLuint& fbo) {
  if (fbo) glDeleteFramebuffers(1, &fbo);
  fbo = 0;
}

struct Program {
  GLuint id = 0;
  GLint loc(const char* name) const { return glGetUniformLocation(id, name); }
  void i1(const char* name, int x) const { glUniform1i(loc(name), x); }
  void f1(const char* name, double x) const { glUniform1f(loc(name), float(x)); }
  void vec3(const char* name, const Eigen::Vector3d& v) const {
    glUniform3f(loc(name), float(v.x()), float(v.y()), float(v.z()));
  }
  void mat4(const char* name, const Eigen::Matrix4d& m) const {
    const Eigen::Matrix4f f = m.cast<float>();
    glUniformMatrix4fv(loc(name), 1, GL_FALSE, f.data());
  }
};

enum class Mode { Surface, Volume };

}  // namespace

struct TetRenderer::Impl {
  // Programs.
  Program geometry, entry, walk[2], resolve[2];  // [Mode]
  GLuint quad_vao = 0, quad_ebo = 0, face_vao = 0, face_ebo = 0;
  GLuint query = 0;
  // Mesh.
  TetTopology topology;
  std::vector<std::array<int, 4>> tets;
  int node_count = 0, tet_rows = 1, node_rows = 1;
  GLsizei face_indices = 0;
  GLuint tet_nodes_tex = 0, neighbours_tex = 0, boundary_tex = 0;
  // State.
  GLuint nodes_tex = 0, plane_tex[4] = {}, gradient_tex = 0, geometry_fbo = 0;
  bool has_state = false;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double diagonal = 0.0;
  double update_ms = 0.0;
  // Table.
  GLuint table_tex = 0;
  // Per-image targets.
  int fb_w = 0, fb_h = 0;
  GLuint entry_tex = 0, zbuffer = 0, entry_fbo = 0;
  GLuint state_a = 0, state_b = 0, state_fbo = 0;
  GLuint colour_tex = 0, depth_tex = 0, out_fbo = 0;
  int pass_cap = kDefaultPassCap;

  int max_texture_size() const {
    GLint size = 0;
    glGetIntegerv(GL_MAX_TEXTURE_SIZE, &size);
    return size;
  }

  void release_targets() {
    for (GLuint* f : {&entry_fbo, &state_fbo, &out_fbo}) delete_framebuffer(*f);
    for (GLuint* t : {&entry_tex, &zbuffer, &state_a, &state_b, &colour_tex, &depth_tex})
      delete_texture(*t);
    fb_w = fb_h = 0;
  }

  void release_state() {
    delete_framebuffer(geometry_fbo);
    delete_texture(nodes_tex);
    for (GLuint& t : plane_tex) delete_texture(t);
    delete_texture(gradient_tex);
    has_state = false;
  }

  void release_mesh() {
    delete_texture(tet_nodes_tex);
    delete_texture(neighbours_tex);
    delete_texture(boundary_tex);
    release_state();
  }

  void ensure_targets(int w, int h) {
    if (entry_fbo && w == fb_w && h == fb_h) return;
    release_targets();
    entry_tex = make_texture_2d(GL_RG32I, w, h, GL_RG_INTEGER, GL_INT, nullptr);
    zbuffer = make_texture_2d(GL_DEPTH_COMPONENT32F, w, h, GL_DEPTH_COMPONENT, GL_FLOAT, nullptr);
    entry_fbo = make_framebuffer({entry_tex}, zbuffer, "section entry");
    // The walk updates its state in place (one read and one write of each texel per draw,
    // glTextureBarrier between draws), only where the entry pass left a depth below 1.
    state_a = make_texture_2d(GL_RGBA32F, w, h, GL_RGBA, GL_FLOAT, nullptr);
    state_b = make_texture_2d(GL_RGBA32F, w, h, GL_RGBA, GL_FLOAT, nullptr);
    state_fbo = make_framebuffer({state_a, state_b}, zbuffer, "walk state");
    colour_tex = make_texture_2d(GL_RGBA8, w, h, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
    depth_tex = make_texture_2d(GL_R32F, w, h, GL_RED, GL_FLOAT, nullptr);
    out_fbo = make_framebuffer({colour_tex, depth_tex}, 0, "image");
    fb_w = w;
    fb_h = h;
  }

  // The table as a 3D texture, uploaded for every frame (outside its timing): a table's address
  // says nothing about its contents.
  void upload_table(const PreintegrationTable& table) {
    const PreintegrationSizes& s = table.sizes();
    delete_texture(table_tex);
    glGenTextures(1, &table_tex);
    glBindTexture(GL_TEXTURE_3D, table_tex);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glTexImage3D(GL_TEXTURE_3D, 0, GL_RGBA32F, s.scalar_samples, s.scalar_samples, s.length_samples,
                 0, GL_RGBA, GL_FLOAT, table.data().data());
    glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    for (GLenum wrap : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R})
      glTexParameteri(GL_TEXTURE_3D, wrap, GL_CLAMP_TO_EDGE);
    if (glGetError() != GL_NO_ERROR) {
      delete_texture(table_tex);
      throw Error("OpenGL: cannot make the " + std::to_string(s.scalar_samples) + "x" +
                  std::to_string(s.scalar_samples) + "x" + std::to_string(s.length_samples) +
                  " pre-integration texture");
    }
  }

  void bind(GLenum unit, GLenum target, GLuint texture) const {
    glActiveTexture(GL_TEXTURE0 + unit);
    glBindTexture(target, texture);
  }

  // The camera in the centred frame (positions less `centre`).
  void set_camera(const Program& p, const Camera& camera, int w, int h) const {
    Eigen::Matrix4d shift = Eigen::Matrix4d::Identity();
    shift.block<3, 1>(0, 3) = centre;
    const Eigen::Matrix4d vp = camera.projection_matrix(double(w) / h) * camera.view() * shift;
    p.mat4("u_view_proj", vp);
    p.mat4("u_inv_view_proj", vp.inverse());
    p.vec3("u_eye", camera.eye - centre);
    p.vec3("u_view_dir", camera.view_direction());
    glUniform2f(p.loc("u_viewport"), float(w), float(h));
    p.i1("u_orthographic", camera.projection == Camera::Projection::Orthographic);
    const bool ortho = camera.projection == Camera::Projection::Orthographic;
    const double aspect = double(w) / h;
    const Eigen::Vector3d f = camera.view_direction();
    const Eigen::Vector3d s = f.cross(camera.up).normalized();
    const Eigen::Vector3d u = s.cross(f);
    const double half =
        ortho ? 0.5 * camera.ortho_height : std::tan(0.5 * camera.fov_y_deg * M_PI / 180.0);
    p.vec3("u_ray_eye", camera.eye - centre);
    p.vec3("u_ray_forward", f);
    p.vec3("u_ray_right", s * (half * aspect));
    p.vec3("u_ray_up", u * half);
    glUniform2f(p.loc("u_ray_planes"), float(camera.near_plane), float(camera.far_plane));
    glUniform2f(p.loc("u_ray_size"), float(w), float(h));
    p.i1("u_ray_orthographic", ortho);
  }

  void set_planes(const Program& p, GLenum first_unit) const {
    const char* names[4] = {"u_plane0", "u_plane1", "u_plane2", "u_plane3"};
    for (int k = 0; k < 4; ++k) {
      bind(first_unit + k, GL_TEXTURE_2D, plane_tex[k]);
      p.i1(names[k], static_cast<int>(first_unit) + k);
    }
  }

  void check_ready() const {
    if (!tet_nodes_tex) throw Error("TetRenderer: no mesh (set_mesh)");
    if (!has_state) throw Error("TetRenderer: no state (set_state)");
  }

  Image render(Mode mode, const Camera& camera, int width, int height,
               const Eigen::Vector3d& background, const Eigen::Vector3d& albedo,
               const PreintegrationTable* table, FrameStats* stats, TetWalkStats* walk_stats);
};

TetRenderer::TetRenderer() : impl_(std::make_unique<Impl>()) {
  auto& m = *impl_;
  const std::string common =
      "#define RAYWARP_TEXTURE_WIDTH " + std::to_string(kTextureWidth) +
      "\n#define RAYWARP_ACTIVE " + std::to_string(kFlagActive) + "\n#define RAYWARP_DONE " +
      std::to_string(kFlagDone) + "\n#define RAYWARP_CAPPED " + std::to_string(kFlagCapped) +
      "\n#define RAYWARP_MAX_PIECES " + std::to_string(kMaxLookupPieces) + "\n";
  std::vector<GLuint> made;
  auto link = [&](const char* vertex, const char* fragment, const std::string& defines) {
    made.push_back(link_program(shader_files(), vertex, fragment, common + defines));
    return Program{made.back()};
  };
  try {
    m.geometry = link(kQuadVertexFile, kGeometryFile, "");
    m.entry = link(kFaceVertexFile, kEntryFile, "");
    m.walk[0] = link(kQuadVertexFile, kWalkFile, "#define RAYWARP_SURFACE 1\n");
    m.walk[1] = link(kQuadVertexFile, kWalkFile, "#define RAYWARP_VOLUME 1\n");
    m.resolve[0] = link(kQuadVertexFile, kResolveFile, "#define RAYWARP_SURFACE 1\n");
    m.resolve[1] = link(kQuadVertexFile, kResolveFile, "#define RAYWARP_VOLUME 1\n");
  } catch (...) {
    for (GLuint p : made) glDeleteProgram(p);
    throw;
  }
  const GLuint corners[3] = {0, 1, 2};
  glGenVertexArrays(1, &m.quad_vao);
  glBindVertexArray(m.quad_vao);
  glGenBuffers(1, &m.quad_ebo);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, m.quad_ebo);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, sizeof corners, corners, GL_STATIC_DRAW);
  glGenVertexArrays(1, &m.face_vao);
  glBindVertexArray(m.face_vao);
  glGenBuffers(1, &m.face_ebo);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, m.face_ebo);
  glBindVertexArray(0);
  glGenQueries(1, &m.query);
}

TetRenderer::~TetRenderer() {
  auto& m = *impl_;
  for (const Program* p :
       {&m.geometry, &m.entry, &m.walk[0], &m.walk[1], &m.resolve[0], &m.resolve[1]})
    glDeleteProgram(p->id);
  GLuint vaos[2] = {m.quad_vao, m.face_vao};
  glDeleteVertexArrays(2, vaos);
  GLuint buffers[2] = {m.quad_ebo, m.face_ebo};
  glDeleteBuffers(2, buffers);
  glDeleteQueries(1, &m.query);
  m.release_mesh();
  m.release_targets();
  delete_texture(m.table_tex);
}

void TetRenderer::set_mesh(const std::vector<std::array<int, 4>>& tets, int node_count) {
  auto& m = *impl_;
  TetTopology topology = tet_topology(tets, node_count);
  const long count = static_cast<long>(tets.size());
  const int limit = m.max_texture_size();
  const long faces = static_cast<long>(topology.boundary.size());
  for (const auto& [what, n] : {std::pair<const char*, long>{"tetrahedra", count},
                                {"nodes", node_count},
                                {"boundary faces", faces}})
    if (rows_for(n) > limit)
      throw Error("TetRenderer: " + std::to_string(n) + " " + what + " need " +
                  std::to_string(rows_for(n)) + " texture rows; the context allows " +
                  std::to_string(limit));
  if (count >= (long(1) << 29))
    throw Error("TetRenderer: " + std::to_string(count) + " tetrahedra; at most 2^29");
  m.release_mesh();
  m.tet_rows = rows_for(count);
  m.node_rows = rows_for(node_count);
  const size_t tet_texels = static_cast<size_t>(kTextureWidth) * m.tet_rows;
  std::vector<GLint> nodes(4 * tet_texels, 0), neighbours(4 * tet_texels, -1);
  for (long t = 0; t < count; ++t)
    for (int k = 0; k < 4; ++k) {
      nodes[4 * t + k] = tets[t][k];
      const int n = topology.neighbour[t][k];
      if (n >= 0) neighbours[4 * t + k] = 4 * n + topology.neighbour_face[t][k];
    }
  m.tet_nodes_tex =
      make_texture_2d(GL_RGBA32I, kTextureWidth, m.tet_rows, GL_RGBA_INTEGER, GL_INT, nodes.data());
  m.neighbours_tex = make_texture_2d(GL_RGBA32I, kTextureWidth, m.tet_rows, GL_RGBA_INTEGER, GL_INT,
                                     neighbours.data());
  const int face_rows = rows_for(faces);
  std::vector<GLint> boundary(2 * static_cast<size_t>(kTextureWidth) * face_rows, -1);
  std::vector<GLuint> indices(3 * faces);
  for (long f = 0; f < faces; ++f) {
    const TetFace& b = topology.boundary[f];
    boundary[2 * f] = b.tet;
    boundary[2 * f + 1] = b.face;
    for (int c = 0; c < 3; ++c)
      indices[3 * f + c] = static_cast<GLuint>(tets[b.tet][kTetFaceVertices[b.face][c]]);
  }
  m.boundary_tex =
      make_texture_2d(GL_RG32I, kTextureWidth, face_rows, GL_RG_INTEGER, GL_INT, boundary.data());
  glBindVertexArray(m.face_vao);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, m.face_ebo);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, indices.size() * sizeof(GLuint), indices.data(),
               GL_STATIC_DRAW);
  glBindVertexArray(0);
  if (glGetError() != GL_NO_ERROR) {
    m.release_mesh();
    throw Error("OpenGL: cannot upload the topology of " + std::to_string(count) + " tetrahedra");
  }
  m.face_indices = static_cast<GLsizei>(indices.size());
  m.topology = std::move(topology);
  m.tets = tets;
  m.node_count = node_count;
}

void TetRenderer::set_state(const std::vector<Eigen::Vector3d>& positions,
                            const std::vector<double>& scalar) {
  auto& m = *impl_;
  if (!m.tet_nodes_tex) throw Error("TetRenderer: set_state before set_mesh");
  if (static_cast<long>(positions.size()) != m.node_count)
    throw Error("TetRenderer: " + std::to_string(positions.size()) + " positions for " +
                std::to_string(m.node_count) + " nodes");
  if (!scalar.empty() && scalar.size() != positions.size())
    throw Error("TetRenderer: " + std::to_string(scalar.size()) + " scalar values for " +
                std::to_string(positions.size()) + " nodes: give one per node, or none");
  Eigen::AlignedBox3d bounds;
  for (const Eigen::Vector3d& p : positions)
    if (p.allFinite()) bounds.extend(p);
  m.centre = bounds.isEmpty() ? Eigen::Vector3d(Eigen::Vector3d::Zero())
                              : Eigen::Vector3d(bounds.center());
  m.diagonal = bounds.isEmpty() ? 0.0 : bounds.diagonal().norm();
  std::vector<float> texels(static_cast<size_t>(kTextureWidth) * m.node_rows * 4, 0.0f);
  for (size_t i = 0; i < positions.size(); ++i) {
    for (int c = 0; c < 3; ++c)
      texels[4 * i + c] = static_cast<float>(positions[i][c] - m.centre[c]);
    texels[4 * i + 3] = scalar.empty() ? 0.0f : static_cast<float>(scalar[i]);
  }
  if (!m.nodes_tex) {
    m.nodes_tex =
        make_texture_2d(GL_RGBA32F, kTextureWidth, m.node_rows, GL_RGBA, GL_FLOAT, texels.data());
    std::vector<GLuint> targets;
    for (GLuint& t : m.plane_tex) {
      t = make_texture_2d(GL_RGBA32F, kTextureWidth, m.tet_rows, GL_RGBA, GL_FLOAT, nullptr);
      targets.push_back(t);
    }
    m.gradient_tex =
        make_texture_2d(GL_RGBA32F, kTextureWidth, m.tet_rows, GL_RGBA, GL_FLOAT, nullptr);
    targets.push_back(m.gradient_tex);
    m.geometry_fbo = make_framebuffer(targets, 0, "tetrahedron geometry");
  } else {
    glBindTexture(GL_TEXTURE_2D, m.nodes_tex);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, kTextureWidth, m.node_rows, 0, GL_RGBA, GL_FLOAT,
                 texels.data());
  }
  // The update pass: one fragment per tetrahedron.
  glFinish();
  const auto start = std::chrono::steady_clock::now();
  glBindFramebuffer(GL_FRAMEBUFFER, m.geometry_fbo);
  glViewport(0, 0, kTextureWidth, m.tet_rows);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  glUseProgram(m.geometry.id);
  m.bind(0, GL_TEXTURE_2D, m.tet_nodes_tex);
  m.bind(1, GL_TEXTURE_2D, m.nodes_tex);
  m.geometry.i1("u_tet_nodes", 0);
  m.geometry.i1("u_nodes", 1);
  m.geometry.i1("u_tet_count", static_cast<int>(m.tets.size()));
  m.geometry.f1("u_degenerate", kDegenerateRelative);
  glBindVertexArray(m.quad_vao);
  glDrawElements(GL_TRIANGLES, 3, GL_UNSIGNED_INT, nullptr);
  glBindVertexArray(0);
  glFinish();
  m.update_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glActiveTexture(GL_TEXTURE0);
  if (glGetError() != GL_NO_ERROR)
    throw Error("OpenGL: cannot update the geometry of " + std::to_string(m.tets.size()) +
                " tetrahedra");
  m.has_state = true;
}

void TetRenderer::set_pass_cap(int passes) {
  if (passes < 1 || passes > 1024)
    throw Error("TetRenderer: pass cap " + std::to_string(passes) + " outside [1, 1024]");
  impl_->pass_cap = passes;
}
int TetRenderer::pass_cap() const { return impl_->pass_cap; }
int TetRenderer::tet_count() const { return static_cast<int>(impl_->tets.size()); }

std::size_t TetRenderer::mesh_bytes() const {
  const Impl& m = *impl_;
  const std::size_t row = kTextureWidth;
  const std::size_t faces = m.topology.boundary.size();
  const std::size_t face_rows = (faces + row - 1) / row;
  return static_cast<std::size_t>(m.tet_rows) * row * (16 + 16 + 4 * 16 + 16) +
         static_cast<std::size_t>(m.node_rows) * row * 16 + face_rows * row * 8 + faces * 12;
}
double TetRenderer::update_milliseconds() const { return impl_->update_ms; }

TetGpuGeometry TetRenderer::geometry() {
  auto& m = *impl_;
  m.check_ready();
  TetGpuGeometry out;
  out.centre = m.centre;
  const size_t count = m.tets.size();
  out.plane.resize(count);
  out.gradient.resize(count);
  std::vector<float> texels(static_cast<size_t>(kTextureWidth) * m.tet_rows * 4);
  glBindFramebuffer(GL_FRAMEBUFFER, m.geometry_fbo);
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  for (int a = 0; a < 5; ++a) {
    glReadBuffer(GL_COLOR_ATTACHMENT0 + a);
    glReadPixels(0, 0, kTextureWidth, m.tet_rows, GL_RGBA, GL_FLOAT, texels.data());
    for (size_t t = 0; t < count; ++t) {
      const Eigen::Vector4f v(texels[4 * t], texels[4 * t + 1], texels[4 * t + 2],
                              texels[4 * t + 3]);
      if (a < 4)
        out.plane[t][a] = v;
      else
        out.gradient[t] = v;
    }
  }
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  return out;
}

Image TetRenderer::render_surface(const Camera& camera, int width, int height,
                                  const RenderSettings& settings, FrameStats* stats,
                                  TetWalkStats* walk) {
  return impl_->render(Mode::Surface, camera, width, height, settings.background, settings.colour,
                       nullptr, stats, walk);
}

Image TetRenderer::render_volume(const Camera& camera, int width, int height,
                                 const PreintegrationTable& table,
                                 const Eigen::Vector3d& background, FrameStats* stats,
                                 TetWalkStats* walk) {
  return impl_->render(Mode::Volume, camera, width, height, background, Eigen::Vector3d::Zero(),
                       &table, stats, walk);
}

Image TetRenderer::Impl::render(Mode mode, const Camera& camera, int width, int height,
                                const Eigen::Vector3d& background, const Eigen::Vector3d& albedo,
                                const PreintegrationTable* table, FrameStats* stats,
                                TetWalkStats* walk_stats) {
  check_ready();
  if (width < 1 || height < 1 || width > 8192 || height > 8192)
    throw Error("TetRenderer: image size " + std::to_string(width) + " x " +
                std::to_string(height) + ": each side must be in [1, 8192]");
  ensure_targets(width, height);
  if (table) upload_table(*table);
  const int mode_index = mode == Mode::Surface ? 0 : 1;
  const Program& wp = walk[mode_index];
  const Program& rp = resolve[mode_index];
  glFinish();
  const auto start = std::chrono::steady_clock::now();

  glViewport(0, 0, width, height);
  glDisable(GL_CULL_FACE);
  // The initial walk state: nothing composited (surface: no hit, t = +inf), no section yet.
  const float inf = std::numeric_limits<float>::infinity();
  const float state_a0[4] = {0.0f, 0.0f, 0.0f, mode == Mode::Surface ? inf : 0.0f};
  const float state_b0[4] = {-inf, 0.0f, inf, 0.0f};
  glBindFramebuffer(GL_FRAMEBUFFER, state_fbo);
  glClearBufferfv(GL_COLOR, 0, state_a0);
  glClearBufferfv(GL_COLOR, 1, state_b0);

  // Uniforms that stay for the frame.
  glUseProgram(entry.id);
  set_camera(entry, camera, width, height);
  set_planes(entry, 0);
  entry.i1("u_boundary", 4);
  entry.i1("u_nodes", 5);
  entry.i1("u_state_b", 6);
  glUseProgram(wp.id);
  set_camera(wp, camera, width, height);
  set_planes(wp, 0);
  wp.i1("u_neighbours", 4);
  wp.i1("u_gradient", 5);
  wp.i1("u_entry", 6);
  wp.i1("u_state_a", 7);
  wp.i1("u_state_b", 8);
  wp.i1("u_table", 9);
  wp.i1("u_step_cap", static_cast<int>(std::min<long>(4L * long(tets.size()) + 1000,
                                                      std::numeric_limits<int>::max())));
  wp.f1("u_diagonal", diagonal);
  wp.f1("u_behind", kBehindTolerance);
  if (table) {
    const PreintegrationSizes& s = table->sizes();
    const int n = s.scalar_samples, l = s.length_samples;
    glUniform3f(wp.loc("u_table_texels"), float(n), float(n), float(l));
    wp.f1("u_s_min", s.s_min);
    wp.f1("u_inv_ds", (n - 1) / (s.s_max - s.s_min));
    wp.f1("u_inv_dl", (l - 1) / s.max_length);
    wp.f1("u_max_length", s.max_length);
    wp.f1("u_termination", 0.99);
  }

  int passes = 0;
  bool cap_reached = false;
  const GLint no_entry[4] = {-1, -1, 0, 0};
  const float one = 1.0f;
  for (int pass = 0; pass < pass_cap + 1; ++pass) {
    // Entries: the nearest front boundary face beyond the previous section's end.
    glBindFramebuffer(GL_FRAMEBUFFER, entry_fbo);
    glDepthMask(GL_TRUE);
    glClearBufferiv(GL_COLOR, 0, no_entry);
    glClearBufferfv(GL_DEPTH, 0, &one);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glUseProgram(entry.id);
    set_planes(entry, 0);
    bind(4, GL_TEXTURE_2D, boundary_tex);
    bind(5, GL_TEXTURE_2D, nodes_tex);
    bind(6, GL_TEXTURE_2D, state_b);
    glBeginQuery(GL_ANY_SAMPLES_PASSED, query);
    glBindVertexArray(face_vao);
    glDrawElements(GL_TRIANGLES, face_indices, GL_UNSIGNED_INT, nullptr);
    glEndQuery(GL_ANY_SAMPLES_PASSED);
    GLuint any = 0;
    glGetQueryObjectuiv(query, GL_QUERY_RESULT, &any);
    if (!any) break;
    if (pass == pass_cap) {
      cap_reached = true;
      break;
    }
    // The walk of this section, in place, at the pixels that got an entry: a full-viewport
    // triangle at window depth 1 passes GL_GREATER only where the entry pass wrote a depth.
    glDepthFunc(GL_GREATER);
    glDepthMask(GL_FALSE);
    glBindFramebuffer(GL_FRAMEBUFFER, state_fbo);
    glUseProgram(wp.id);
    set_planes(wp, 0);
    bind(4, GL_TEXTURE_2D, neighbours_tex);
    bind(5, GL_TEXTURE_2D, gradient_tex);
    bind(6, GL_TEXTURE_2D, entry_tex);
    bind(7, GL_TEXTURE_2D, state_a);
    bind(8, GL_TEXTURE_2D, state_b);
    if (table) bind(9, GL_TEXTURE_3D, table_tex);
    glTextureBarrier();
    glBindVertexArray(quad_vao);
    glDrawElements(GL_TRIANGLES, 3, GL_UNSIGNED_INT, nullptr);
    ++passes;
  }

  // The image.
  glDisable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDepthMask(GL_TRUE);
  glBindFramebuffer(GL_FRAMEBUFFER, out_fbo);
  auto encode = [](double c) { return float(srgb_encode(c)); };
  const float clear_colour[4] = {encode(background.x()), encode(background.y()),
                                 encode(background.z()), 1.0f};
  const float far_depth[4] = {inf, 0, 0, 0};
  glClearBufferfv(GL_COLOR, 0, clear_colour);
  glClearBufferfv(GL_COLOR, 1, far_depth);
  glUseProgram(rp.id);
  set_camera(rp, camera, width, height);
  rp.vec3("u_albedo", albedo);
  rp.vec3("u_background", background);
  rp.i1("u_state_a", 0);
  rp.i1("u_state_b", 1);
  bind(0, GL_TEXTURE_2D, state_a);
  bind(1, GL_TEXTURE_2D, state_b);
  glBindVertexArray(quad_vao);
  glDrawElements(GL_TRIANGLES, 3, GL_UNSIGNED_INT, nullptr);
  glBindVertexArray(0);
  glFinish();
  const auto stop = std::chrono::steady_clock::now();
  glActiveTexture(GL_TEXTURE0);

  long nonfinite = 0;
  Image image = read_back_image(width, height, clear_colour, &nonfinite);
  if (walk_stats) {
    TetWalkStats& w = *walk_stats;
    w = TetWalkStats{};
    w.passes = passes;
    w.pass_cap_reached = cap_reached;
    std::vector<float> a(static_cast<size_t>(width) * height * 4), b(a.size());
    glBindFramebuffer(GL_FRAMEBUFFER, state_fbo);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    glReadBuffer(GL_COLOR_ATTACHMENT0);
    glReadPixels(0, 0, width, height, GL_RGBA, GL_FLOAT, a.data());
    glReadBuffer(GL_COLOR_ATTACHMENT1);
    glReadPixels(0, 0, width, height, GL_RGBA, GL_FLOAT, b.data());
    for (size_t i = 0; i < static_cast<size_t>(width) * height; ++i) {
      const int code = static_cast<int>(b[4 * i + 3]);
      const int sections = code >> 2;
      const long steps = static_cast<long>(b[4 * i + 1]);
      ++w.rays;
      w.entered += sections > 0;
      w.capped += (code & 3) == kFlagCapped;
      if (mode == Mode::Surface) w.hits += std::isfinite(a[4 * i + 3]);
      if (static_cast<int>(w.sections_histogram.size()) <= sections)
        w.sections_histogram.resize(sections + 1, 0);
      ++w.sections_histogram[sections];
      w.max_sections = std::max(w.max_sections, sections);
      w.max_steps = std::max(w.max_steps, steps);
      w.total_steps += steps;
    }
  }
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  if (glGetError() != GL_NO_ERROR)
    throw Error("OpenGL: the tetrahedral walk of a " + std::to_string(width) + "x" +
                std::to_string(height) + " image failed");
  if (stats) {
    stats->milliseconds = std::chrono::duration<double, std::milli>(stop - start).count();
    stats->nonfinite_pixels = nonfinite;
  }
  return image;
}

}  // namespace raywarp::gl
