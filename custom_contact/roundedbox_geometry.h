/* Rounded boxes for LIGGGHTS 3.8: where two of them touch, and where one touches a triangle.
 *
 * Written for dem-orchestrator. A rounded box is a sphero-polyhedron: an inner box of half extents
 * h (body axes) swept by a sphere of radius r (the study's brick: 14.5 x 6.5 x 3 mm inside, r = 1 mm,
 * so 31 x 15 x 8 mm outside; Richefeu et al. 2012). Its surface within r of the inner box's faces is
 * flat, within r of its edges cylindrical, within r of its vertices spherical, so every contact
 * between two of them is one of the inner boxes' features (a vertex, an edge) within r_A + r_B of a
 * feature of the other, and each such pair of features is a contact point of its own:
 *
 *   vertex of A against box B (and vertex of B against box A): the closest point of the other inner
 *     box to the vertex, whatever feature it lies on (face, edge or vertex); keyed by the vertex, so
 *     a vertex that slides from a face over an edge keeps its history (the surface it meets is smooth);
 *   edge of A against edge of B, not parallel, closest points within both segments, each edge's
 *     outward normal cone holding the contact normal; keyed by the two edges.
 *
 * A face lying on a face then gives the corners of their overlap polygon (16 points when two
 * bricks are aligned: at each corner both vertices and both crossing edge pairs; 8 when offset,
 * 4 edge pairs when crossed at 90 degrees), each carrying its own normal force, so the resultant
 * can sit anywhere in the overlap and the friction's moment is carried as on a real face.
 *
 * Conventions: the normal points from B to A (the force on A is +f_n n), the overlap is
 * r_A + r_B minus the inner features' distance, the contact point lies midway through the overlap.
 * Keys: 0-7 A's vertex against B, 8-15 B's vertex against A, 16 + 12 eA + eB an edge pair;
 * against a triangle, the box's vertex index 0-7.
 */
#ifndef DEMORCH_ROUNDEDBOX_GEOMETRY_H
#define DEMORCH_ROUNDEDBOX_GEOMETRY_H

#include <cmath>

namespace RoundedBox {

struct Box {
  double c[3];     // centre (m)
  double R[3][3];  // body to world: column k is body axis k in world coordinates
  double h[3];     // inner half extents (m)
  double r;        // rounding radius (m)
};

struct SubContact {
  int key;
  double point[3];   // contact point (m), midway through the overlap
  double normal[3];  // unit, from B to A
  double overlap;    // m, > 0
};

// Most sub-contacts two boxes can have: 16 vertices + 144 edge pairs (a bound, never reached).
const int MAX_PAIR = 160;
const int MAX_WALL = 8;

inline double dot(const double *a, const double *b) { return a[0]*b[0] + a[1]*b[1] + a[2]*b[2]; }
inline void cross(const double *a, const double *b, double *out)
{
  out[0] = a[1]*b[2] - a[2]*b[1];
  out[1] = a[2]*b[0] - a[0]*b[2];
  out[2] = a[0]*b[1] - a[1]*b[0];
}

/* Body to world rotation of a unit quaternion (w, x, y, z), as LIGGGHTS' MathExtra::quat_to_mat. */
inline void quaternionToMatrix(const double *q, double R[3][3])
{
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  R[0][0] = w*w + x*x - y*y - z*z; R[0][1] = 2.0*(x*y - w*z);         R[0][2] = 2.0*(x*z + w*y);
  R[1][0] = 2.0*(x*y + w*z);         R[1][1] = w*w - x*x + y*y - z*z; R[1][2] = 2.0*(y*z - w*x);
  R[2][0] = 2.0*(x*z - w*y);         R[2][1] = 2.0*(y*z + w*x);         R[2][2] = w*w - x*x - y*y + z*z;
}

inline void toWorld(const Box &b, const double *local, double *world)
{
  for (int i = 0; i < 3; i++)
    world[i] = b.c[i] + b.R[i][0]*local[0] + b.R[i][1]*local[1] + b.R[i][2]*local[2];
}

inline void toLocal(const Box &b, const double *world, double *local)
{
  const double d[3] = { world[0] - b.c[0], world[1] - b.c[1], world[2] - b.c[2] };
  for (int k = 0; k < 3; k++)
    local[k] = b.R[0][k]*d[0] + b.R[1][k]*d[1] + b.R[2][k]*d[2];
}

/* Vertex v (bits 0, 1, 2: + along axes 0, 1, 2) of the inner box, world coordinates. */
inline void vertex(const Box &b, int v, double *world)
{
  const double local[3] = { (v & 1) ? b.h[0] : -b.h[0], (v & 2) ? b.h[1] : -b.h[1], (v & 4) ? b.h[2] : -b.h[2] };
  toWorld(b, local, world);
}

/* Edge e = 4 axis + s of an inner box (axis: its direction; bit 0 of s: + along the next axis,
 * bit 1: + along the one after): its first end (world), unit direction, length, and the two other
 * axes with the edge's signs along them (its outward normal cone). */
struct Edge {
  double start[3], direction[3], length;
  int axes[2];
  double signs[2];
};

inline void edge(const Box &b, int e, Edge &out)
{
  const int k = e / 4, s = e % 4;
  out.axes[0] = (k + 1) % 3;
  out.axes[1] = (k + 2) % 3;
  out.signs[0] = (s & 1) ? 1.0 : -1.0;
  out.signs[1] = (s & 2) ? 1.0 : -1.0;
  double local[3];
  local[k] = -b.h[k];
  local[out.axes[0]] = out.signs[0] * b.h[out.axes[0]];
  local[out.axes[1]] = out.signs[1] * b.h[out.axes[1]];
  toWorld(b, local, out.start);
  for (int i = 0; i < 3; i++) out.direction[i] = b.R[i][k];
  out.length = 2.0 * b.h[k];
}

/* One vertex against the other box. `flip`: the vertex belongs to B (the normal then points from
 * the box that owns the closest point, A, to the vertex, reversed to keep "from B to A"). */
inline bool vertexAgainstBox(const double *p, double r_vertex, const Box &other, bool flip, int key, SubContact &out)
{
  const double reach = r_vertex + other.r;
  // in the other box's frame first: most vertices are out of reach, and need no more
  double u[3], clamped[3];
  toLocal(other, p, u);
  for (int k = 0; k < 3; k++) clamped[k] = u[k] < -other.h[k] ? -other.h[k] : (u[k] > other.h[k] ? other.h[k] : u[k]);
  const double gap[3] = { u[0] - clamped[0], u[1] - clamped[1], u[2] - clamped[2] };
  if (dot(gap, gap) >= reach * reach) return false;
  double q[3];
  toWorld(other, clamped, q);
  const double distance = std::sqrt(dot(gap, gap));
  if (distance >= reach || distance <= 1e-12 * reach) return false;  // apart, or inner boxes interpenetrating
  const double sign = flip ? -1.0 : 1.0;
  out.key = key;
  out.overlap = reach - distance;
  for (int i = 0; i < 3; i++) out.normal[i] = sign * (p[i] - q[i]) / distance;
  // midway through the overlap, along the line from q to p
  const double along = other.r - 0.5 * out.overlap;
  for (int i = 0; i < 3; i++) out.point[i] = q[i] + (p[i] - q[i]) / distance * along;
  return true;
}

/* Whether a direction (world) lies in the outward normal cone of an edge of a box: its components
 * along the edge's two other axes have the edge's signs, or lean out of the cone by less than 0.01
 * (0.6 degrees). Where two faces lie on each other the normal is on the cone's boundary (a face's
 * normal), and a rotation of 1e-9 rad would otherwise switch the corners' edge pairs on and off,
 * and with them their histories; leaning out that little, the edge pair's normal is the face's to
 * within 0.6 degrees. */
inline bool inEdgeCone(const Box &b, const double *n, const int *axes, const double *signs)
{
  const double tolerance = 1e-2;
  for (int m = 0; m < 2; m++) {
    const int k = axes[m];
    const double component = b.R[0][k]*n[0] + b.R[1][k]*n[1] + b.R[2][k]*n[2];
    if (signs[m] * component < -tolerance) return false;
  }
  return true;
}

inline bool edgeAgainstEdge(const Box &A, const Edge &ea, const Box &B, const Edge &eb, int key, SubContact &out)
{
  const double *a0 = ea.start, *da = ea.direction, *b0 = eb.start, *db = eb.direction;
  const double la = ea.length, lb = eb.length;
  const double w0[3] = { a0[0] - b0[0], a0[1] - b0[1], a0[2] - b0[2] };
  const double cosine = dot(da, db), d = dot(da, w0), e = dot(db, w0);
  const double denominator = 1.0 - cosine * cosine;
  if (denominator < 1e-13) return false;  // parallel (the test below, sine < 1e-6, decides near it)
  const double s = (cosine * e - d) / denominator;  // along A's edge from its start (m)
  const double t = (e - cosine * d) / denominator;  // along B's edge
  // within both segments; a crossing at an end, to 1e-6 of the length, counts (aligned bricks)
  if (s < -1e-6 * la || s > la * (1.0 + 1e-6) || t < -1e-6 * lb || t > lb * (1.0 + 1e-6)) return false;
  double n[3];
  cross(da, db, n);
  const double sine = std::sqrt(dot(n, n));
  if (sine < 1e-6) return false;  // parallel: their ends' vertex contacts carry them
  for (int i = 0; i < 3; i++) n[i] /= sine;
  double pa[3], pb[3];
  for (int i = 0; i < 3; i++) { pa[i] = a0[i] + s * da[i]; pb[i] = b0[i] + t * db[i]; }
  const double gap_dir[3] = { pa[0] - pb[0], pa[1] - pb[1], pa[2] - pb[2] };
  double gap = dot(n, gap_dir);
  // orient n from B to A: -n in A's edge cone, n in B's
  const double minus_n[3] = { -n[0], -n[1], -n[2] };
  if (!(inEdgeCone(A, minus_n, ea.axes, ea.signs) && inEdgeCone(B, n, eb.axes, eb.signs))) {
    if (!(inEdgeCone(A, n, ea.axes, ea.signs) && inEdgeCone(B, minus_n, eb.axes, eb.signs))) return false;
    for (int i = 0; i < 3; i++) n[i] = -n[i];
    gap = -gap;
  }
  const double reach = A.r + B.r;
  if (gap >= reach || gap <= 1e-12 * reach) return false;
  out.key = key;
  out.overlap = reach - gap;
  for (int i = 0; i < 3; i++) {
    out.normal[i] = n[i];
    out.point[i] = pb[i] + n[i] * (B.r - 0.5 * out.overlap);
  }
  return true;
}

/* Whether the two outer boxes (inner half extents + rounding) are apart along one of the 15 axes of
 * the separating axis test (Gottschalk, Lin & Manocha 1996, OBBTree): a cheap no for most
 * neighbours; a yes may still have no sub-contact (the rounded corners lie inside the outer box). */
inline bool outerBoxesApart(const Box &A, const Box &B)
{
  double ea[3], eb[3], Rab[3][3], absR[3][3], t[3];
  for (int k = 0; k < 3; k++) { ea[k] = A.h[k] + A.r; eb[k] = B.h[k] + B.r; }
  const double d[3] = { B.c[0] - A.c[0], B.c[1] - A.c[1], B.c[2] - A.c[2] };
  for (int i = 0; i < 3; i++) {
    t[i] = A.R[0][i] * d[0] + A.R[1][i] * d[1] + A.R[2][i] * d[2];  // in A's frame
    for (int j = 0; j < 3; j++) {
      Rab[i][j] = A.R[0][i] * B.R[0][j] + A.R[1][i] * B.R[1][j] + A.R[2][i] * B.R[2][j];
      absR[i][j] = std::fabs(Rab[i][j]) + 1e-12;
    }
  }
  for (int i = 0; i < 3; i++)
    if (std::fabs(t[i]) > ea[i] + eb[0] * absR[i][0] + eb[1] * absR[i][1] + eb[2] * absR[i][2]) return true;
  for (int j = 0; j < 3; j++) {
    const double along = t[0] * Rab[0][j] + t[1] * Rab[1][j] + t[2] * Rab[2][j];
    if (std::fabs(along) > eb[j] + ea[0] * absR[0][j] + ea[1] * absR[1][j] + ea[2] * absR[2][j]) return true;
  }
  for (int i = 0; i < 3; i++) {
    const int i1 = (i + 1) % 3, i2 = (i + 2) % 3;
    for (int j = 0; j < 3; j++) {
      const int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
      const double ra = ea[i1] * absR[i2][j] + ea[i2] * absR[i1][j];
      const double rb = eb[j1] * absR[i][j2] + eb[j2] * absR[i][j1];
      if (std::fabs(t[i2] * Rab[i1][j] - t[i1] * Rab[i2][j]) > ra + rb) return true;
    }
  }
  return false;
}

/* Whether an edge may come within `reach` of a box's inner box: the box around the edge's two ends,
 * in that box's frame, meets the inner box grown by `reach` (a cheap cull before the edge pairs: an
 * edge lying above a face on the far side of its own box is out). */
inline bool edgeNearBox(const Edge &e, const Box &b, double reach)
{
  double end[3], u0[3], u1[3];
  for (int k = 0; k < 3; k++) end[k] = e.start[k] + e.length * e.direction[k];
  toLocal(b, e.start, u0);
  toLocal(b, end, u1);
  for (int k = 0; k < 3; k++) {
    const double limit = b.h[k] + reach;
    if ((u0[k] > limit && u1[k] > limit) || (u0[k] < -limit && u1[k] < -limit)) return false;
  }
  return true;
}

/* Every sub-contact between two rounded boxes (A first: callers put the lower atom tag as A, so the
 * same pair gives the same numbers on every process). Returns how many were written to out. */
inline int boxBoxContacts(const Box &A, const Box &B, SubContact *out)
{
  // bounding spheres, then the outer boxes' separating axes
  const double d[3] = { A.c[0] - B.c[0], A.c[1] - B.c[1], A.c[2] - B.c[2] };
  const double ra = std::sqrt(dot(A.h, A.h)) + A.r, rb = std::sqrt(dot(B.h, B.h)) + B.r;
  if (dot(d, d) >= (ra + rb) * (ra + rb)) return 0;
  if (outerBoxesApart(A, B)) return 0;
  int n = 0;
  double p[3];
  for (int v = 0; v < 8; v++) {
    vertex(A, v, p);
    if (vertexAgainstBox(p, A.r, B, false, v, out[n])) n++;
  }
  for (int v = 0; v < 8; v++) {
    vertex(B, v, p);
    if (vertexAgainstBox(p, B.r, A, true, 8 + v, out[n])) n++;
  }
  // edge pairs, among the edges of each box that come near the other
  const double reach = A.r + B.r;
  Edge ea[12], eb[12];
  int near_a[12], near_b[12], na = 0, nb = 0;
  for (int e = 0; e < 12; e++) {
    edge(A, e, ea[e]);
    if (edgeNearBox(ea[e], B, reach)) near_a[na++] = e;
    edge(B, e, eb[e]);
    if (edgeNearBox(eb[e], A, reach)) near_b[nb++] = e;
  }
  for (int i = 0; i < na; i++)
    for (int j = 0; j < nb; j++)
      if (edgeAgainstEdge(A, ea[near_a[i]], B, eb[near_b[j]], 16 + 12 * near_a[i] + near_b[j], out[n])) n++;
  return n;
}

/* Projection q of p on the plane of triangle (a, b, c); whether it lies inside the triangle (its
 * barycentric coordinates all >= -1e-9, so a point over an edge shared by two triangles is inside
 * both, never neither). */
inline bool projectOnTriangle(const double *p, const double *a, const double *b, const double *c, double *q)
{
  double ab[3], ac[3], ap[3], n[3];
  for (int i = 0; i < 3; i++) { ab[i] = b[i] - a[i]; ac[i] = c[i] - a[i]; ap[i] = p[i] - a[i]; }
  cross(ab, ac, n);
  const double area2 = dot(n, n);
  if (area2 <= 0.0) return false;
  const double height = dot(ap, n) / area2;
  for (int i = 0; i < 3; i++) q[i] = p[i] - height * n[i];
  double aq[3], t[3];
  for (int i = 0; i < 3; i++) aq[i] = q[i] - a[i];
  cross(aq, ac, t);
  const double v = dot(t, n) / area2;   // weight of b
  cross(ab, aq, t);
  const double w = dot(t, n) / area2;   // weight of c
  const double tolerance = -1e-9;
  return v >= tolerance && w >= tolerance && 1.0 - v - w >= tolerance;
}

/* A box's vertices against one triangle (a wall: no thickness, no rounding). Only vertices over the
 * triangle's inside count: a vertex over an edge shared by two coplanar triangles would otherwise
 * touch both, and a wall's rim is met by a brick's vertices over its triangles. The normal points
 * from the wall to the box (the box is A). Returns how many were written. */
inline int boxTriangleContacts(const Box &A, const double *a, const double *b, const double *c, SubContact *out)
{
  double centre_projection[3];
  projectOnTriangle(A.c, a, b, c, centre_projection);
  const double offset[3] = { A.c[0] - centre_projection[0], A.c[1] - centre_projection[1], A.c[2] - centre_projection[2] };
  const double bound = std::sqrt(dot(A.h, A.h)) + A.r;
  if (dot(offset, offset) >= bound * bound) return 0;  // farther from the triangle's plane than the body reaches
  int n = 0;
  double p[3], q[3];
  for (int v = 0; v < 8; v++) {
    vertex(A, v, p);
    if (!projectOnTriangle(p, a, b, c, q)) continue;
    const double d[3] = { p[0] - q[0], p[1] - q[1], p[2] - q[2] };
    const double distance = std::sqrt(dot(d, d));
    if (distance >= A.r || distance <= 1e-12 * A.r) continue;
    SubContact &s = out[n++];
    s.key = v;
    s.overlap = A.r - distance;
    for (int i = 0; i < 3; i++) {
      s.normal[i] = d[i] / distance;
      s.point[i] = q[i] - 0.5 * s.overlap * s.normal[i];
    }
  }
  return n;
}

}  // namespace RoundedBox

#endif
