#include "gl/renderer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <string>

#include "base/error.h"
#include "gl/gl_api.h"
#include "gl/shader_sources.h"

namespace raywarp::gl {

namespace {

Eigen::Matrix4f to_float(const Eigen::Matrix4d& m) { return m.cast<float>(); }

struct Uniforms {
  GLuint program;
  GLint loc(const char* name) const { return glGetUniformLocation(program, name); }
  void mat4(const char* name, const Eigen::Matrix4d& m) const {
    Eigen::Matrix4f f = to_float(m);  // column-major, as GL expects
    glUniformMatrix4fv(loc(name), 1, GL_FALSE, f.data());
  }
  void mat3(const char* name, const Eigen::Matrix3d& m) const {
    Eigen::Matrix3f f = m.cast<float>();
    glUniformMatrix3fv(loc(name), 1, GL_FALSE, f.data());
  }
  void vec3(const char* name, const Eigen::Vector3d& v) const {
    glUniform3f(loc(name), float(v.x()), float(v.y()), float(v.z()));
  }
  void vec4(const char* name, const Eigen::Vector4d& v) const {
    glUniform4f(loc(name), float(v.x()), float(v.y()), float(v.z()), float(v.w()));
  }
  void f1(const char* name, double x) const { glUniform1f(loc(name), float(x)); }
  void i1(const char* name, int x) const { glUniform1i(loc(name), x); }
};

GLuint upload_3d(GLenum internal, GLenum format, const Eigen::Vector3i& dims, const float* data) {
  GLuint tex = 0;
  glGenTextures(1, &tex);
  glBindTexture(GL_TEXTURE_3D, tex);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTexImage3D(GL_TEXTURE_3D, 0, internal, dims.x(), dims.y(), dims.z(), 0, format, GL_FLOAT, data);
  glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  for (GLenum wrap : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R})
    glTexParameteri(GL_TEXTURE_3D, wrap, GL_CLAMP_TO_EDGE);
  if (glGetError() != GL_NO_ERROR)
    throw Error("OpenGL: cannot create a " + std::to_string(dims.x()) + "x" +
                std::to_string(dims.y()) + "x" + std::to_string(dims.z()) + " 3D texture");
  return tex;
}

struct BoxGpu {
  BoxTextures data;  // box, grids' mappings (the texel arrays are on the GPU)
  GLuint textures[kTextureUnitCount] = {};  // by TextureUnit; 0: the box has none there
  size_t bytes = 0;
  GLuint& texture(TextureUnit u) { return textures[static_cast<size_t>(u)]; }
};

// The scene's sampling method's feature, for a box that is not sphere traced: "bounded" is only
// uses_bounded's to decide, and a box it does not apply to is sampled linearly.
Feature sampling_feature(Sampling sampling) {
  for (const FeatureInfo& f : kFeatures)
    if (f.sampling == sampling && f.feature != Feature::SamplingBounded) return f.feature;
  return Feature::SamplingLinear;
}

Feature cut_feature(CutMode mode) {
  switch (mode) {
    case CutMode::Hollow:
      return Feature::CutHollow;
    case CutMode::Solid:
      return Feature::CutSolid;
    case CutMode::ThickShell:
      return Feature::CutThick;
  }
  throw Error("unknown cut mode " + std::to_string(static_cast<int>(mode)));
}

// Copies the mappings of a grid, not its texels.
template <class T>
void copy_mapping(Grid3<T>& to, const Grid3<T>& from) {
  to.origin = from.origin;
  to.spacing = from.spacing;
  to.dims = from.dims;
}

}  // namespace

Image read_back_image(int width, int height, const float clear[4], long* nonfinite) {
  Image image(width, height);
  std::vector<uint8_t> rgba(static_cast<size_t>(width) * height * 4);
  std::vector<float> depth(static_cast<size_t>(width) * height);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadBuffer(GL_COLOR_ATTACHMENT0);
  glReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
  glReadBuffer(GL_COLOR_ATTACHMENT1);
  glReadPixels(0, 0, width, height, GL_RED, GL_FLOAT, depth.data());
  long bad_pixels = 0;
  for (int y = 0; y < height; ++y) {
    const size_t src = static_cast<size_t>(height - 1 - y) * width;
    const size_t dst = static_cast<size_t>(y) * width;
    for (int x = 0; x < width; ++x) {
      const float z = depth[src + x];
      const bool bad = std::isnan(z) || z == -std::numeric_limits<float>::infinity();
      bad_pixels += bad;
      image.depth[dst + x] = bad ? std::numeric_limits<float>::infinity() : z;
      for (int c = 0; c < 4; ++c)
        image.rgba[4 * (dst + x) + c] =
            bad ? static_cast<uint8_t>(std::lround(clear[c] * 255.0f)) : rgba[4 * (src + x) + c];
    }
  }
  if (nonfinite) *nonfinite = bad_pixels;
  return image;
}

bool uses_bounded(const BoxTextures& b, const RenderSettings& settings) {
  if (!traces_bounded(settings.sampling, b.has_cut, b.moves_nothing)) return false;
  if (b.step_bounds.empty())
    throw Error("render.sampling = \"bounded\" needs the box's step bounds (bake_step_bounds)");
  if (!b.texture_map.isIdentity(0.0))
    throw Error(
        "render.sampling = \"bounded\": its step bounds hold for the deformation texture as "
        "baked, not read through a texture map M; re-bake instead of mapping");
  return true;
}

Variant raycast_variant(const BoxTextures& b, const RenderSettings& settings) {
  Variant v;
  if (b.has_cut) v.add(Feature::Cut).add(cut_feature(b.cut_mode));
  if (b.cylindrical() && !b.texture_map.isIdentity(0.0))
    throw Error(
        "a cylindrical texture is read at p', not through a texture map M; re-bake instead");
  if (b.moves_nothing)
    v.add(Feature::MovesNothing);
  else if (!b.texture_map.isIdentity(0.0))
    v.add(Feature::TextureMap);
  if (b.cylindrical()) v.add(Feature::Cylindrical);
  const bool bounded = uses_bounded(b, settings);
  if (!bounded && skipping_pays(b, settings.step_voxels, settings.skipping)) v.add(Feature::Skip);
  v.add(bounded ? Feature::SamplingBounded : sampling_feature(settings.sampling));
  if (b.uses_depth_cube) v.add(Feature::DepthCube);
  return v;
}

std::string raycast_defines(const BoxTextures& b, const RenderSettings& settings) {
  return raycast_variant(b, settings).defines();
}

std::string raycast_fragment_source(const BoxTextures& b, const RenderSettings& settings) {
  return assemble_shader("raycast.frag.glsl",
                         raycast_defines(b, settings) + stage_defines(GL_FRAGMENT_SHADER));
}

struct Renderer::Impl {
  GLuint raster = 0;
  bool ray_cast = true;                                  // pass 2 (set_ray_cast)
  std::map<unsigned long, GLuint> raycast;               // by Variant::key
  std::map<unsigned long, std::string> raycast_defines;  // the defines of each, for a reload
  std::shared_ptr<const ShaderFiles> files;              // null: the embedded ones
  const ShaderFiles& shader_files() const { return files ? *files : ShaderFiles::embedded(); }

  static std::string raster_defines() {
    return "#define RAYWARP_MAX_BOXES " + std::to_string(kMaxBoxes) + "\n";
  }
  GLuint mesh_vao = 0, mesh_vbo[2] = {0, 0}, mesh_ebo = 0;
  GLsizei mesh_indices = 0;
  GLuint cube_vao = 0, cube_vbo = 0, cube_ebo = 0;
  std::vector<BoxGpu> boxes;
  GLuint fbo = 0, colour_tex = 0, depth_tex = 0, zbuffer = 0;
  int fbo_w = 0, fbo_h = 0;

  void release_boxes() {
    for (auto& b : boxes)
      for (GLuint& t : b.textures)
        if (t) glDeleteTextures(1, &t);
    boxes.clear();
  }

  void ensure_framebuffer(int w, int h) {
    if (fbo && w == fbo_w && h == fbo_h) return;
    if (fbo) {
      glDeleteFramebuffers(1, &fbo);
      GLuint t[3] = {colour_tex, depth_tex, zbuffer};
      glDeleteTextures(3, t);
    }
    auto tex2d = [&](GLenum internal, GLenum format, GLenum type) {
      GLuint t = 0;
      glGenTextures(1, &t);
      glBindTexture(GL_TEXTURE_2D, t);
      glTexImage2D(GL_TEXTURE_2D, 0, internal, w, h, 0, format, type, nullptr);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
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

  // The ray-cast program of a box's variant: only the code its features need. Its samplers read
  // the units of kTextureUnits.
  GLuint raycast_program(const Variant& variant) {
    auto found = raycast.find(variant.key());
    if (found != raycast.end()) return found->second;
    const GLuint program = link_raycast(shader_files(), variant.defines());
    raycast.emplace(variant.key(), program);
    raycast_defines.emplace(variant.key(), variant.defines());
    return program;
  }

  static GLuint link_raycast(const ShaderFiles& table, const std::string& defines) {
    GLuint program = link_program(table, "raycast.vert.glsl", "raycast.frag.glsl", defines);
    glUseProgram(program);
    for (const TextureUnitInfo& t : kTextureUnits)  // -1 (ignored): the variant reads none there
      glUniform1i(glGetUniformLocation(program, t.sampler), unit_number(t.unit));
    return program;
  }

  void set_camera(const Uniforms& u, const Camera& camera, int w, int h) {
    Eigen::Matrix4d vp = camera.projection_matrix(double(w) / h) * camera.view();
    u.mat4("u_view_proj", vp);
    u.mat4("u_inv_view_proj", vp.inverse());
    u.vec3("u_eye", camera.eye);
    u.vec3("u_view_dir", camera.view_direction());
    glUniform2f(u.loc("u_viewport"), float(w), float(h));
    u.i1("u_orthographic", camera.projection == Camera::Projection::Orthographic);
    u.vec3("u_albedo", Eigen::Vector3d::Zero());
  }
};

Renderer::Renderer() : impl_(std::make_unique<Impl>()) {
  impl_->raster = link_program(ShaderFiles::embedded(), "raster.vert.glsl", "raster.frag.glsl",
                               Impl::raster_defines());
  // The unit cube [0, 1]^3, scaled onto each box's ray-cast region by the vertex shader.
  const float corners[8][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0},
                               {0, 0, 1}, {1, 0, 1}, {0, 1, 1}, {1, 1, 1}};
  // Counter-clockwise seen from outside.
  const unsigned faces[36] = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                              2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
  glGenVertexArrays(1, &impl_->cube_vao);
  glBindVertexArray(impl_->cube_vao);
  glGenBuffers(1, &impl_->cube_vbo);
  glBindBuffer(GL_ARRAY_BUFFER, impl_->cube_vbo);
  glBufferData(GL_ARRAY_BUFFER, sizeof corners, corners, GL_STATIC_DRAW);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
  glEnableVertexAttribArray(0);
  glGenBuffers(1, &impl_->cube_ebo);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, impl_->cube_ebo);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, sizeof faces, faces, GL_STATIC_DRAW);
  glBindVertexArray(0);
}

Renderer::~Renderer() {
  impl_->release_boxes();
  glDeleteProgram(impl_->raster);
  for (auto& [key, program] : impl_->raycast) glDeleteProgram(program);
  GLuint vaos[2] = {impl_->mesh_vao, impl_->cube_vao};
  glDeleteVertexArrays(2, vaos);
  GLuint buffers[5] = {impl_->mesh_vbo[0], impl_->mesh_vbo[1], impl_->mesh_ebo, impl_->cube_vbo,
                       impl_->cube_ebo};
  glDeleteBuffers(5, buffers);
  if (impl_->fbo) {
    glDeleteFramebuffers(1, &impl_->fbo);
    GLuint t[3] = {impl_->colour_tex, impl_->depth_tex, impl_->zbuffer};
    glDeleteTextures(3, t);
  }
}

void Renderer::set_mesh(const Mesh& mesh) {
  auto& m = *impl_;
  if (!m.mesh_vao) {
    glGenVertexArrays(1, &m.mesh_vao);
    glGenBuffers(2, m.mesh_vbo);
    glGenBuffers(1, &m.mesh_ebo);
  }
  Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> positions = mesh.V.cast<float>();
  Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> normals =
      vertex_normals(mesh).cast<float>();
  glBindVertexArray(m.mesh_vao);
  glBindBuffer(GL_ARRAY_BUFFER, m.mesh_vbo[0]);
  glBufferData(GL_ARRAY_BUFFER, positions.size() * sizeof(float), positions.data(), GL_STATIC_DRAW);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
  glEnableVertexAttribArray(0);
  glBindBuffer(GL_ARRAY_BUFFER, m.mesh_vbo[1]);
  glBufferData(GL_ARRAY_BUFFER, normals.size() * sizeof(float), normals.data(), GL_STATIC_DRAW);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
  glEnableVertexAttribArray(1);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, m.mesh_ebo);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, mesh.F.size() * sizeof(int), mesh.F.data(), GL_STATIC_DRAW);
  glBindVertexArray(0);
  m.mesh_indices = static_cast<GLsizei>(mesh.F.size());
}

void Renderer::set_texture_map(size_t box, const Eigen::Matrix4d& texture_map,
                               const Eigen::AlignedBox3d& region, double lipschitz) {
  if (box >= impl_->boxes.size())
    throw Error("set_texture_map: box " + std::to_string(box) + " of " +
                std::to_string(impl_->boxes.size()));
  BoxTextures& d = impl_->boxes[box].data;
  d.texture_map = texture_map;
  d.region = region;
  d.lipschitz = lipschitz;
}

void Renderer::set_boxes(const std::vector<BoxTextures>& boxes) {
  std::vector<const BoxTextures*> pointers;
  for (const BoxTextures& b : boxes) pointers.push_back(&b);
  set_boxes(pointers);
}

void Renderer::set_boxes(const std::vector<const BoxTextures*>& boxes) {
  if (boxes.size() > static_cast<size_t>(kMaxBoxes))
    throw Error("at most " + std::to_string(kMaxBoxes) + " boxes per scene, got " +
                std::to_string(boxes.size()));
  impl_->release_boxes();
  for (const BoxTextures* box : boxes) {
    const BoxTextures& b = *box;
    BoxGpu gpu;
    BoxTextures& d = gpu.data;
    d.box = b.box;
    copy_mapping(d.sdf.grid, b.sdf.grid);
    d.sdf.background = b.sdf.background;
    copy_mapping(d.deformation.grid, b.deformation.grid);
    d.region = ray_cast_region(b);
    d.moves_nothing = b.moves_nothing;
    d.lipschitz = b.lipschitz;
    d.texture_map = b.texture_map;
    d.cylindrical_axis = b.cylindrical_axis;
    d.has_cut = b.has_cut;
    d.cut_mode = b.cut_mode;
    d.shell_thickness = b.shell_thickness;
    d.half_precision = b.half_precision;
    const GLenum r_format = b.half_precision ? GL_R16F : GL_R32F;
    const size_t channel_bytes = b.half_precision ? 2 : 4;
    if (b.uses_depth_cube) {
      if (b.depth_cube.empty()) throw Error("a depth-cube box has no depth maps");
      d.uses_depth_cube = true;
      d.depth_cube.half_extents = b.depth_cube.half_extents;
      d.depth_cube.spacing = b.depth_cube.spacing;
      d.depth_cube.far_depth = b.depth_cube.far_depth;
      for (int k = 0; k < 6; ++k) {  // the mappings; the texels go to the GPU
        DepthMap& m = d.depth_cube.maps[k];
        m = b.depth_cube.maps[k];
        m.depth.clear();
      }
      const DepthCube::Layers layers = b.depth_cube.layers();
      gpu.texture(TextureUnit::DepthCube) = upload_3d(
          r_format, GL_RED, Eigen::Vector3i(layers.width, layers.height, DepthCube::Layers::kDepth),
          b.depth_cube.layer_texels().data());
      gpu.bytes = b.depth_cube.texture_bytes(static_cast<int>(channel_bytes));
    } else {
      gpu.texture(TextureUnit::Sdf) =
          upload_3d(r_format, GL_RED, b.sdf.grid.dims, b.sdf.grid.data.data());
      gpu.bytes = b.sdf.grid.size() * channel_bytes;
    }
    if (!b.moves_nothing) {
      gpu.texture(TextureUnit::Deformation) =
          upload_3d(b.half_precision ? GL_RGBA16F : GL_RGBA32F, GL_RGBA, b.deformation.grid.dims,
                    reinterpret_cast<const float*>(b.deformation.grid.data.data()));
      if (b.cylindrical())  // the angle is periodic
        glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_WRAP_S, GL_REPEAT);
      gpu.bytes += b.deformation.grid.size() * 4 * channel_bytes;
    }
    if (b.has_cut) {
      if (b.alpha.grid.size() == 0) throw Error("a cut box has no alpha map");
      copy_mapping(d.alpha.grid, b.alpha.grid);
      gpu.texture(TextureUnit::Alpha) =
          upload_3d(r_format, GL_RED, b.alpha.grid.dims, b.alpha.grid.data.data());
      if (b.cylindrical()) glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_WRAP_S, GL_REPEAT);
      gpu.bytes += b.alpha.grid.size() * channel_bytes;
    }
    if (!b.step_bounds.empty()) {
      // Brick bounds for the bounded tracer, read texel by texel (texelFetch).
      auto upload_bricks = [&](const Grid3<float>& g) {
        const GLuint tex = upload_3d(GL_R32F, GL_RED, g.dims, g.data.data());
        glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
        glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
        gpu.bytes += g.size() * 4;
        return tex;
      };
      gpu.texture(TextureUnit::Bricks) = upload_bricks(b.step_bounds.bricks);
      gpu.texture(TextureUnit::SdfBricks) = upload_bricks(b.step_bounds.sdf_bricks);
      d.step_bounds = b.step_bounds;  // the mappings; the texels stay (a few KiB)
    }
    impl_->boxes.push_back(gpu);
  }
}

void Renderer::set_shader_files(const ShaderFiles& files) {
  // Every program first, so that a file that does not compile changes nothing.
  std::vector<GLuint> made;
  std::map<unsigned long, GLuint> raycast;
  try {
    made.push_back(
        link_program(files, "raster.vert.glsl", "raster.frag.glsl", Impl::raster_defines()));
    for (const auto& [key, defines] : impl_->raycast_defines) {
      made.push_back(Impl::link_raycast(files, defines));
      raycast[key] = made.back();
    }
  } catch (...) {
    for (GLuint p : made) glDeleteProgram(p);
    throw;
  }
  glDeleteProgram(impl_->raster);
  for (auto& [key, program] : impl_->raycast) glDeleteProgram(program);
  impl_->raster = made.front();
  impl_->raycast = std::move(raycast);
  impl_->files = std::make_shared<const ShaderFiles>(files);
}

void Renderer::set_ray_cast(bool on) { impl_->ray_cast = on; }

size_t Renderer::texture_bytes() const {
  size_t n = 0;
  for (const auto& b : impl_->boxes) n += b.bytes;
  return n;
}

Image Renderer::render(const Camera& camera, int width, int height, const RenderSettings& settings,
                       FrameStats* stats) {
  auto& m = *impl_;
  m.ensure_framebuffer(width, height);
  // Compile the boxes' shader variants first, so that the frame time is the frame's.
  if (m.ray_cast)
    for (const auto& b : m.boxes) m.raycast_program(raycast_variant(b.data, settings));
  glFinish();
  auto start = std::chrono::steady_clock::now();
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

  const bool any_cut =
      std::any_of(m.boxes.begin(), m.boxes.end(), [](const BoxGpu& b) { return b.data.has_cut; });

  // Pass 1: the mesh outside the boxes.
  Uniforms raster{m.raster};
  glUseProgram(m.raster);
  m.set_camera(raster, camera, width, height);
  raster.vec3("u_albedo", settings.colour);
  raster.vec3("u_inside_colour", settings.inside_colour);
  raster.i1("u_two_sided", any_cut);
  raster.i1("u_box_count", static_cast<int>(m.boxes.size()));
  for (size_t i = 0; i < m.boxes.size(); ++i) {
    char name[64];
    Eigen::Matrix4d to_box = m.boxes[i].data.box.local_to_object().inverse();
    std::snprintf(name, sizeof name, "u_object_to_box[%zu]", i);
    raster.mat4(name, to_box);
    std::snprintf(name, sizeof name, "u_half_extents[%zu]", i);
    raster.vec3(name, m.boxes[i].data.box.half_extents);
  }
  if (m.mesh_indices > 0) {
    glBindVertexArray(m.mesh_vao);
    glDrawElements(GL_TRIANGLES, m.mesh_indices, GL_UNSIGNED_INT, nullptr);
  }

  // Pass 2: per box, ray cast over its region; back faces only, so it also runs with the camera
  // inside the region.
  glEnable(GL_CULL_FACE);
  glCullFace(GL_FRONT);
  glBindVertexArray(m.cube_vao);
  for (const auto& b : m.boxes) {
    if (!m.ray_cast) break;
    const Variant variant = raycast_variant(b.data, settings);
    const GLuint program = m.raycast_program(variant);
    Uniforms rc{program};
    glUseProgram(program);
    m.set_camera(rc, camera, width, height);
    rc.vec3("u_albedo", settings.colour);
    rc.vec3("u_inside_colour", settings.inside_colour);
    rc.vec3("u_cut_colour", settings.cut_colour);
    rc.i1("u_max_steps", settings.max_steps);
    rc.i1("u_refine_steps", settings.refine_steps);
    const auto& sdf = b.data.sdf.grid;
    const double voxel = implicit_spacing(b.data);  // the distance grid's, or the depth maps'
    const auto& def = b.data.deformation.grid;
    const auto& alpha = b.data.alpha.grid;
    rc.mat4("u_box_to_object", b.data.box.local_to_object());
    rc.mat4("u_object_to_box", b.data.box.local_to_object().inverse());
    rc.mat3("u_box_to_object_dir", b.data.box.rotation);
    rc.vec3("u_half_extents", b.data.box.half_extents);
    rc.vec3("u_region_lower", b.data.region.min());
    rc.vec3("u_region_upper", b.data.region.max());
    rc.vec3("u_sdf_origin", sdf.origin);
    rc.vec3("u_sdf_size", sdf.extent());
    rc.f1("u_sdf_spacing", voxel);
    rc.f1("u_background", implicit_background(b.data));
    rc.vec3("u_def_origin", def.origin);
    rc.vec3("u_def_size", def.extent());
    rc.vec3("u_def_spacing", deformation_step(b.data));
    // The textures are uploaded in object units: no decode in the shader.
    rc.vec4("u_def_decode", Eigen::Vector4d::Ones());
    rc.f1("u_sdf_decode", 1.0);
    rc.f1("u_alpha_decode", 1.0);
    const Eigen::Matrix4d& map = b.data.texture_map;  // its rows: march.glsl's convention
    rc.vec4("u_texture_map_x", map.row(0).transpose());
    rc.vec4("u_texture_map_y", map.row(1).transpose());
    rc.vec4("u_texture_map_z", map.row(2).transpose());
    rc.vec3("u_alpha_origin", alpha.origin);
    rc.vec3("u_alpha_size", alpha.extent());
    rc.vec3("u_alpha_spacing", alpha_step(b.data));
    if (variant.has(Feature::Cylindrical)) {
      const int a = b.data.cylindrical_axis;
      rc.vec3("u_cyl_e_u", Eigen::Vector3d::Unit((a + 1) % 3));
      rc.vec3("u_cyl_e_v", Eigen::Vector3d::Unit((a + 2) % 3));
      rc.vec3("u_cyl_e_a", Eigen::Vector3d::Unit(a));
    }
    rc.f1("u_thickness", b.data.shell_thickness);
    rc.f1("u_lipschitz", b.data.lipschitz);
    rc.f1("u_cut_margin", cut_margin(b.data));
    rc.f1("u_step", settings.step_voxels * voxel);
    rc.f1("u_threshold", settings.threshold_voxels * voxel);
    rc.f1("u_fine_factor", settings.fine_factor);
    rc.f1("u_seam", kSeamVoxels * voxel);
    if (variant.has(Feature::SamplingBounded)) {
      const StepBounds& sb = b.data.step_bounds;
      rc.vec3("u_brick_origin", sb.bricks.origin);
      rc.vec3("u_brick_spacing", sb.bricks.spacing);
      rc.vec3("u_sdf_brick_origin", sb.sdf_bricks.origin);
      rc.f1("u_sdf_brick_spacing", sb.sdf_bricks.voxel());
      rc.f1("u_inv_lipschitz_w", sb.validity_lipschitz > 0.0 ? 1.0 / sb.validity_lipschitz : 0.0);
      rc.f1("u_epsilon", settings.hit_epsilon_voxels * voxel);
    }
    if (variant.has(Feature::DepthCube)) {
      const DepthCube& cube = b.data.depth_cube;
      for (int a = 0; a < 3; ++a) {
        const DepthMap& m = cube.maps[2 * a];
        const std::string axis(1, "xyz"[a]);
        glUniform2f(rc.loc(("u_depth_origin_" + axis).c_str()), float(m.origin.x()),
                    float(m.origin.y()));
        glUniform2f(rc.loc(("u_depth_last_" + axis).c_str()), float(m.nu - 1), float(m.nv - 1));
      }
      const DepthCube::Layers layers = cube.layers();
      glUniform2f(rc.loc("u_depth_layer"), float(layers.width), float(layers.height));
    }
    for (const TextureUnitInfo& t : kTextureUnits) {
      glActiveTexture(GL_TEXTURE0 + unit_number(t.unit));
      glBindTexture(t.target, b.textures[static_cast<size_t>(t.unit)]);
    }
    glActiveTexture(GL_TEXTURE0);
    glDrawElements(GL_TRIANGLES, 36, GL_UNSIGNED_INT, nullptr);
  }
  glDisable(GL_CULL_FACE);
  glFinish();
  auto stop = std::chrono::steady_clock::now();

  long nonfinite = 0;
  Image image = read_back_image(width, height, background, &nonfinite);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  if (stats) {
    stats->milliseconds = std::chrono::duration<double, std::milli>(stop - start).count();
    stats->nonfinite_pixels = nonfinite;
  }
  return image;
}

}  // namespace raywarp::gl
