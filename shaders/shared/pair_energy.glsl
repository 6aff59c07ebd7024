// The pair term of the particle energy (seed paper Eq. 1-2; DESIGN.md), shared by the tree walk's leaves and the
// neighbour-list energy so both evaluate a pair with the same float arithmetic (reference ref::particle_energy):
//   d_ij = |p_i - p_j| / (2 cos(pi/6) min(h_i, h_j)),  E_ij = cot(d pi/2) + d pi/2 - pi/2 for d <= 1, else 0.
#ifndef CPMESH_PAIR_ENERGY_GLSL
#define CPMESH_PAIR_ENERGY_GLSL

const float PI = 3.14159265358979;
const float SUPPORT = 1.7320508075688772;  // 2 cos(pi/6)

// delta = p_i - p_j, r = |delta|, scale = SUPPORT min(h_i, h_j). Adds E_ij to energy and dE_ij/dp_i to grad when
// they interact (d < 1) and returns whether they did.
bool add_pair_energy(const vec3 delta, const float r, const float scale, inout float energy, inout vec3 grad) {
  const float d = max(r / scale, 1e-3);
  if (d >= 1.0) return false;
  const float x = d * PI * 0.5;
  const float c = cos(x) / sin(x);
  energy += c + x - PI * 0.5;
  // dE/dd = -(pi/2) cot^2; dd/dp_i = delta / (r scale)
  if (r > 0.0) grad += (-0.5 * PI * c * c) * delta / (r * scale);
  return true;
}

#endif
