// The planes of tetrahedron t.
uniform sampler2D u_plane0;
uniform sampler2D u_plane1;
uniform sampler2D u_plane2;
uniform sampler2D u_plane3;
void planes_of(int t, out vec4 plane[4]) {
  ivec2 p = texel(t);
  plane[0] = texelFetch(u_plane0, p, 0);
  plane[1] = texelFetch(u_plane1, p, 0);
  plane[2] = texelFetch(u_plane2, p, 0);
  plane[3] = texelFetch(u_plane3, p, 0);
}
