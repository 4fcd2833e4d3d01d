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

#include <algorithm>
#include <cmath>

namespace RoundedBox {

struct Box {
  double c[3];     // centre (m)
  double R[3][3];  // body to world: column k is body axis k in world coordinates
  double h[3];     // inner half extents (m)
  double r;        // rounding radius (m)
  double bound;    // bounding radius |h| + r (m): a corner's sphere is the farthest surface
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

/* Vertex v (bits 0, 1, 2: + along axes 0, 1, 2) of the inner box, world coordinates. */
inline void vertex(const Box &b, int v, double *world)
{
  const double local[3] = { (v & 1) ? b.h[0] : -b.h[0], (v & 2) ? b.h[1] : -b.h[1], (v & 4) ? b.h[2] : -b.h[2] };
  toWorld(b, local, world);
}

/* Two boxes seen from each other, computed once per pair: B's axes and centre in A's frame, and
 * each box's inner vertices in the other's frame. Every test below works in one box's frame, where
 * that box is axis-aligned; only the sub-contacts found are turned into world coordinates. */
struct Pose {
  double R[3][3];       // R[i][j]: B's axis j along A's axis i
  double t[3];          // B's centre in A's frame (m)
  double a_in_b[8][3];  // A's vertex v in B's frame (m)
  double b_in_a[8][3];  // B's vertex v in A's frame (m)
};

/* B's axes and centre in A's frame (all the separating axis test needs). */
inline void relativeFrame(const Box &A, const Box &B, Pose &p)
{
  const double d[3] = { B.c[0] - A.c[0], B.c[1] - A.c[1], B.c[2] - A.c[2] };
  for (int i = 0; i < 3; i++) {
    p.t[i] = A.R[0][i] * d[0] + A.R[1][i] * d[1] + A.R[2][i] * d[2];
    for (int j = 0; j < 3; j++) p.R[i][j] = A.R[0][i] * B.R[0][j] + A.R[1][i] * B.R[1][j] + A.R[2][i] * B.R[2][j];
  }
}

/* What the vertices in the other's frame are made of: A's centre in B's frame, and each box's half
 * extents along its axes in the other's frame ([k]: along axis k). */
struct Axes {
  double a_centre[3], a_axes[3][3], b_axes[3][3];
};

inline void relativeAxes(const Box &A, const Box &B, const Pose &p, Axes &x)
{
  for (int j = 0; j < 3; j++) x.a_centre[j] = -(p.R[0][j] * p.t[0] + p.R[1][j] * p.t[1] + p.R[2][j] * p.t[2]);
  for (int k = 0; k < 3; k++)
    for (int m = 0; m < 3; m++) {
      x.b_axes[k][m] = B.h[k] * p.R[m][k];  // B's axis k in A's frame: column k
      x.a_axes[k][m] = A.h[k] * p.R[k][m];  // A's axis k in B's frame: row k
    }
}

/* Vertex v of B in A's frame (b_in_a) or of A in B's frame, summed in one order: the same numbers
 * whether one vertex or all are made. */
inline void vertexInOther(const double *centre, const double (*axes)[3], int v, double *out)
{
  for (int m = 0; m < 3; m++) {
    double w = centre[m];
    for (int k = 0; k < 3; k++) {
      if ((v >> k) & 1) w += axes[k][m];
      else w -= axes[k][m];
    }
    out[m] = w;
  }
}

/* Each box's inner vertices in the other's frame, from the relative frame. */
inline void relativeVertices(const Box &A, const Box &B, Pose &p)
{
  Axes x;
  relativeAxes(A, B, p, x);
  for (int v = 0; v < 8; v++) {
    vertexInOther(p.t, x.b_axes, v, p.b_in_a[v]);
    vertexInOther(x.a_centre, x.a_axes, v, p.a_in_b[v]);
  }
}

/* Whether a point (coordinates u in a box's frame) lies inside the box, to 1e-9 of its half extents. */
inline bool insideBox(const double *u, const double *h)
{
  for (int k = 0; k < 3; k++)
    if (std::fabs(u[k]) > h[k] * (1.0 + 1e-9)) return false;
  return true;
}

/* A vertex (coordinates u in the frame of box `other`) against that box. `flip`: the vertex belongs
 * to B and `other` is A (the normal then points from A's closest point to the vertex, reversed to
 * keep "from B to A"). A vertex inside the other inner box (an overlap beyond r_A + r_B: an impact
 * faster than the stiffness holds) is pushed out through the nearest face, its overlap r_A + r_B
 * plus its depth under that face: the force keeps growing, continuous with the outside, and keeps
 * the vertex's history. */
inline bool vertexAgainstBox(const double *u, double r_vertex, const Box &other, bool flip, int key, SubContact &out)
{
  const double reach = r_vertex + other.r;
  double clamped[3];
  for (int k = 0; k < 3; k++) clamped[k] = u[k] < -other.h[k] ? -other.h[k] : (u[k] > other.h[k] ? other.h[k] : u[k]);
  const double gap[3] = { u[0] - clamped[0], u[1] - clamped[1], u[2] - clamped[2] };
  const double squared = dot(gap, gap);
  if (squared >= reach * reach) return false;
  double distance = std::sqrt(squared);
  double q[3], direction[3];  // the closest point (world), the unit direction from it to the vertex
  if (distance > 1e-12 * reach) {
    toWorld(other, clamped, q);
    for (int i = 0; i < 3; i++) direction[i] = (other.R[i][0] * gap[0] + other.R[i][1] * gap[1] + other.R[i][2] * gap[2]) / distance;
  } else {  // inside the inner box: the nearest face
    int face = 0;
    for (int k = 1; k < 3; k++)
      if (other.h[k] - std::fabs(u[k]) < other.h[face] - std::fabs(u[face])) face = k;
    const double side = u[face] < 0.0 ? -1.0 : 1.0;
    distance = std::fabs(u[face]) - other.h[face];  // <= 0: the depth under the face, negative
    double on_face[3] = { u[0], u[1], u[2] };
    on_face[face] = side * other.h[face];
    toWorld(other, on_face, q);
    for (int i = 0; i < 3; i++) direction[i] = side * other.R[i][face];
  }
  const double sign = flip ? -1.0 : 1.0;
  out.key = key;
  out.overlap = reach - distance;
  // midway through the overlap, along the line from q to the vertex
  const double along = other.r - 0.5 * out.overlap;
  for (int i = 0; i < 3; i++) {
    out.normal[i] = sign * direction[i];
    out.point[i] = q[i] + direction[i] * along;
  }
  return true;
}

/* Edge e = 4 axis + s of an inner box (axis: its direction; bit 0 of s: + along the next axis,
 * bit 1: + along the one after): its two end vertices, the first at - along the axis. */
const int EDGE_START[12] = { 0, 2, 4, 6, 0, 4, 1, 5, 0, 1, 2, 3 };
inline int edgeStart(int e) { return EDGE_START[e]; }
inline int edgeEnd(int e) { return EDGE_START[e] | (1 << (e / 4)); }

/* Where a point lies against a box grown by `reach` (its frame): bit 2k set when beyond the + face
 * of axis k, bit 2k + 1 beyond the - face. Two points with a bit in common lie beyond the same face,
 * and so does the segment between them (Cohen & Sutherland's outcodes). */
inline int outcode(const double *u, const Box &b, double reach)
{
  int code = 0;
  for (int k = 0; k < 3; k++) {
    const double limit = b.h[k] + reach;
    code |= (u[k] > limit) << (2 * k);
    code |= (u[k] < -limit) << (2 * k + 1);
  }
  return code;
}

/* Whether a direction lies in the outward normal cone of edge e of a box, given the direction's
 * components along that box's three axes: its components along the edge's two other axes have the
 * edge's signs, or lean out of the cone by less than 0.01 (0.6 degrees). Where two faces lie on
 * each other the normal is on the cone's boundary (a face's normal), and a rotation of 1e-9 rad would
 * otherwise switch the corners' edge pairs on and off, and with them their histories; leaning out
 * that little, the edge pair's normal is the face's to within 0.6 degrees. */
inline bool inEdgeCone(const double *components, int e)
{
  const double tolerance = 1e-2;
  const int k = e / 4, s = e % 4;
  const double first = (s & 1) ? components[(k + 1) % 3] : -components[(k + 1) % 3];
  const double second = (s & 2) ? components[(k + 2) % 3] : -components[(k + 2) % 3];
  return first >= -tolerance && second >= -tolerance;
}

/* Edge ea of A against edge eb of B, in A's frame, once edgePairMayTouch let them through. */
inline bool edgeAgainstEdge(const Box &A, int ea, const Box &B, int eb, const Pose &p, int key, SubContact &out)
{
  const int ka = ea / 4, kb = eb / 4;
  const double la = 2.0 * A.h[ka], lb = 2.0 * B.h[kb];
  double a0[3];
  const int start = edgeStart(ea);
  for (int m = 0; m < 3; m++) a0[m] = (start >> m) & 1 ? A.h[m] : -A.h[m];
  const double *b0 = p.b_in_a[edgeStart(eb)], *b1 = p.b_in_a[edgeEnd(eb)];
  const double reach = A.r + B.r;
  const double db[3] = { p.R[0][kb], p.R[1][kb], p.R[2][kb] };  // A's edge runs along A's axis ka
  const double w0[3] = { a0[0] - b0[0], a0[1] - b0[1], a0[2] - b0[2] };
  const double cosine = db[ka], d = w0[ka], e = dot(db, w0);
  const double denominator = 1.0 - cosine * cosine;
  if (denominator < 1e-13) return false;  // parallel (the test below, sine < 1e-6, decides near it)
  const double s = (cosine * e - d) / denominator;  // along A's edge from its start (m)
  const double t = (e - cosine * d) / denominator;  // along B's edge
  // within both segments; a crossing at an end, to 1e-6 of the length, counts (aligned bricks)
  if (s < -1e-6 * la || s > la * (1.0 + 1e-6) || t < -1e-6 * lb || t > lb * (1.0 + 1e-6)) return false;
  double n[3] = { 0.0, 0.0, 0.0 };  // A's axis ka cross db
  n[(ka + 1) % 3] = -db[(ka + 2) % 3];
  n[(ka + 2) % 3] = db[(ka + 1) % 3];
  const double sine = std::sqrt(dot(n, n));
  if (sine < 1e-6) return false;  // parallel: their ends' vertex contacts carry them
  for (int i = 0; i < 3; i++) n[i] /= sine;
  double pa[3], pb[3];
  for (int i = 0; i < 3; i++) { pa[i] = a0[i]; pb[i] = b0[i] + t * db[i]; }
  pa[ka] += s;
  const double gap_dir[3] = { pa[0] - pb[0], pa[1] - pb[1], pa[2] - pb[2] };
  double gap = dot(n, gap_dir);
  // orient n from B to A: -n in A's edge cone, n in B's (n's components along B's axes: Rᵀ n)
  double in_a[3], in_b[3];
  for (int k = 0; k < 3; k++) { in_a[k] = -n[k]; in_b[k] = p.R[0][k] * n[0] + p.R[1][k] * n[1] + p.R[2][k] * n[2]; }
  if (!(inEdgeCone(in_a, ea) && inEdgeCone(in_b, eb))) {
    for (int k = 0; k < 3; k++) { in_a[k] = -in_a[k]; in_b[k] = -in_b[k]; }
    if (!(inEdgeCone(in_a, ea) && inEdgeCone(in_b, eb))) return false;
    for (int i = 0; i < 3; i++) n[i] = -n[i];
    gap = -gap;
  }
  if (gap >= reach) return false;
  if (gap <= 1e-12 * reach) {
    // the inner edges crossed (an overlap beyond r_A + r_B): a real crossing puts each closest point
    // inside the other inner box; otherwise the two edges face each other across a body, no contact
    double pa_in_b[3];
    for (int j = 0; j < 3; j++)
      pa_in_b[j] = p.R[0][j] * (pa[0] - p.t[0]) + p.R[1][j] * (pa[1] - p.t[1]) + p.R[2][j] * (pa[2] - p.t[2]);
    if (!insideBox(pb, A.h) || !insideBox(pa_in_b, B.h)) return false;
  }
  out.key = key;
  out.overlap = reach - gap;
  double point[3];
  for (int i = 0; i < 3; i++) point[i] = pb[i] + n[i] * (B.r - 0.5 * out.overlap);
  toWorld(A, point, out.point);
  for (int i = 0; i < 3; i++) out.normal[i] = A.R[i][0] * n[0] + A.R[i][1] * n[1] + A.R[i][2] * n[2];
  return true;
}

/* Edge eb of B in A's frame: the box around it, and whether it may meet A's inner box (where two
 * inner edges can cross, an overlap beyond r_A + r_B). */
struct EdgeBox {
  double low[3], high[3];
  bool inner;
};

inline void edgeBox(const Box &A, const Pose &p, int eb, EdgeBox &box)
{
  const double *b0 = p.b_in_a[edgeStart(eb)], *b1 = p.b_in_a[edgeEnd(eb)];
  box.inner = true;
  for (int m = 0; m < 3; m++) {
    box.low[m] = std::min(b0[m], b1[m]);
    box.high[m] = std::max(b0[m], b1[m]);
    if (box.low[m] > A.h[m] * (1.0 + 1e-9) || box.high[m] < -A.h[m] * (1.0 + 1e-9)) box.inner = false;
  }
}

/* Whether edge ea of A and a B edge in box `b` may touch (a necessary condition of edgeAgainstEdge,
 * much cheaper): the edges' boxes, grown by the reach, meet and, unless B's edge may reach into A's
 * inner box, B's edge reaches into the outward region of A's edge (a contact's normal lies in A's
 * edge cone, to the cone's 0.01: inEdgeCone). */
inline bool edgePairMayTouch(const Box &A, int ea, const EdgeBox &b, double reach)
{
  const int ka = ea / 4, k1 = (ka + 1) % 3, k2 = (ka + 2) % 3;
  if (b.low[ka] > A.h[ka] + reach || b.high[ka] < -A.h[ka] - reach) return false;
  const double a1 = (ea & 1) ? A.h[k1] : -A.h[k1], a2 = (ea & 2) ? A.h[k2] : -A.h[k2];
  if (b.low[k1] > a1 + reach || b.high[k1] < a1 - reach) return false;
  if (b.low[k2] > a2 + reach || b.high[k2] < a2 - reach) return false;
  if (b.inner) return true;
  const double lean = 1e-2 * reach;
  const double out1 = (ea & 1) ? b.high[k1] - a1 : a1 - b.low[k1];
  const double out2 = (ea & 2) ? b.high[k2] - a2 : a2 - b.low[k2];
  return out1 >= -lean && out2 >= -lean;
}

/* How far apart the two outer boxes (inner half extents + rounding) are along the first of the 15
 * axes of the separating axis test (Gottschalk, Lin & Manocha 1996, OBBTree) that parts them: a
 * cheap no for most neighbours. Returns a lower bound of the distance between the two bodies (m,
 * > 0: the outer boxes hold them) or -1 when no axis parts them (they may still have no
 * sub-contact: the rounded corners lie inside the outer box). On an edge-pair axis the gap is
 * measured along the unnormalised cross product, whose length is at most 1: a lower bound. */
inline double outerBoxesApart(const Box &A, const Box &B, const Pose &p)
{
  double ea[3], eb[3], absR[3][3];
  const double (*Rab)[3] = p.R;
  const double *t = p.t;
  for (int k = 0; k < 3; k++) { ea[k] = A.h[k] + A.r; eb[k] = B.h[k] + B.r; }
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) absR[i][j] = std::fabs(Rab[i][j]) + 1e-12;
  for (int i = 0; i < 3; i++) {
    const double gap = std::fabs(t[i]) - (ea[i] + eb[0] * absR[i][0] + eb[1] * absR[i][1] + eb[2] * absR[i][2]);
    if (gap > 0.0) return gap;
  }
  for (int j = 0; j < 3; j++) {
    const double along = t[0] * Rab[0][j] + t[1] * Rab[1][j] + t[2] * Rab[2][j];
    const double gap = std::fabs(along) - (eb[j] + ea[0] * absR[0][j] + ea[1] * absR[1][j] + ea[2] * absR[2][j]);
    if (gap > 0.0) return gap;
  }
  for (int i = 0; i < 3; i++) {
    const int i1 = (i + 1) % 3, i2 = (i + 2) % 3;
    for (int j = 0; j < 3; j++) {
      const int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
      const double ra = ea[i1] * absR[i2][j] + ea[i2] * absR[i1][j];
      const double rb = eb[j1] * absR[i][j2] + eb[j2] * absR[i][j1];
      const double gap = std::fabs(t[i2] * Rab[i1][j] - t[i1] * Rab[i2][j]) - (ra + rb);
      if (gap > 0.0) return gap;
    }
  }
  return -1.0;
}

/* How far apart two bodies are by their bounding spheres, then their outer boxes' separating axes: a
 * lower bound of their distance (m, > 0), or -1 when neither parts them. */
inline double boxesApart(const Box &A, const Box &B)
{
  const double d[3] = { A.c[0] - B.c[0], A.c[1] - B.c[1], A.c[2] - B.c[2] };
  const double reach_both = A.bound + B.bound;
  const double squared = dot(d, d);
  if (squared >= reach_both * reach_both) {
    const double apart = std::sqrt(squared) - reach_both;
    return apart > 0.0 ? apart : -1.0;
  }
  Pose p;
  relativeFrame(A, B, p);
  return outerBoxesApart(A, B, p);
}

/* Every sub-contact between two rounded boxes that boxesApart does not part (A first: callers put
 * the lower atom tag as A, so the same pair gives the same numbers on every process). Returns how
 * many were written to out. */
inline int boxBoxContacts(const Box &A, const Box &B, SubContact *out)
{
  Pose p;
  relativeFrame(A, B, p);
  relativeVertices(A, B, p);
  // each vertex against the other inner box grown by the reach: a vertex beyond one of its faces
  // touches nothing, an edge whose two ends are beyond the same face neither
  const double reach = A.r + B.r;
  int code_a[8], code_b[8];
  for (int v = 0; v < 8; v++) {
    code_a[v] = outcode(p.a_in_b[v], B, reach);
    code_b[v] = outcode(p.b_in_a[v], A, reach);
  }
  int n = 0;
  for (int v = 0; v < 8; v++)
    if (!code_a[v] && vertexAgainstBox(p.a_in_b[v], A.r, B, false, v, out[n])) n++;
  for (int v = 0; v < 8; v++)
    if (!code_b[v] && vertexAgainstBox(p.b_in_a[v], B.r, A, true, 8 + v, out[n])) n++;
  // edge pairs, among the edges of each box that come near the other
  int near_a[12], near_b[12], na = 0, nb = 0;
  for (int e = 0; e < 12; e++) {
    if (!(code_a[edgeStart(e)] & code_a[edgeEnd(e)])) near_a[na++] = e;
    if (!(code_b[edgeStart(e)] & code_b[edgeEnd(e)])) near_b[nb++] = e;
  }
  if (!na || !nb) return n;
  EdgeBox boxes[12];
  for (int j = 0; j < nb; j++) edgeBox(A, p, near_b[j], boxes[j]);
  for (int i = 0; i < na; i++)
    for (int j = 0; j < nb; j++)
      if (edgePairMayTouch(A, near_a[i], boxes[j], reach)
          && edgeAgainstEdge(A, near_a[i], B, near_b[j], p, 16 + 12 * near_a[i] + near_b[j], out[n])) n++;
  return n;
}

/* A wall triangle (a, b, c), with what every test against it needs, made once per step. */
struct Triangle {
  double a[3], ab[3], ac[3];
  double n[3];        // ab x ac
  double area2;       // |n|^2 (m^4); 0: degenerate, never touched
  double unit[3];     // n / |n|
  double lo[3], hi[3];  // its bounding box (m)
};

inline void triangle(const double *a, const double *b, const double *c, Triangle &t)
{
  for (int i = 0; i < 3; i++) {
    t.a[i] = a[i];
    t.ab[i] = b[i] - a[i];
    t.ac[i] = c[i] - a[i];
    t.lo[i] = std::min(a[i], std::min(b[i], c[i]));
    t.hi[i] = std::max(a[i], std::max(b[i], c[i]));
  }
  cross(t.ab, t.ac, t.n);
  t.area2 = dot(t.n, t.n);
  const double norm = std::sqrt(t.area2);
  for (int i = 0; i < 3; i++) t.unit[i] = norm > 0.0 ? t.n[i] / norm : 0.0;
}

/* Whether the projection q of p on the triangle's plane lies inside the triangle (its barycentric
 * coordinates all >= -1e-9, so a point over an edge shared by two triangles is inside both, never
 * neither). */
inline bool projectOnTriangle(const double *p, const Triangle &tri, double *q)
{
  const double ap[3] = { p[0] - tri.a[0], p[1] - tri.a[1], p[2] - tri.a[2] };
  const double height = dot(ap, tri.n) / tri.area2;
  for (int i = 0; i < 3; i++) q[i] = p[i] - height * tri.n[i];
  double aq[3], t[3];
  for (int i = 0; i < 3; i++) aq[i] = q[i] - tri.a[i];
  cross(aq, tri.ac, t);
  const double v = dot(t, tri.n) / tri.area2;   // weight of b
  cross(tri.ab, aq, t);
  const double w = dot(t, tri.n) / tri.area2;   // weight of c
  const double tolerance = -1e-9;
  return v >= tolerance && w >= tolerance && 1.0 - v - w >= tolerance;
}

/* A box's vertices against one triangle (a wall: no thickness, no rounding). Only vertices over the
 * triangle's inside count: a vertex over an edge shared by two coplanar triangles would otherwise
 * touch both, and a wall's rim is met by a brick's vertices over its triangles. The normal points
 * from the wall to the box (the box is A). Returns how many were written. */
inline int boxTriangleContacts(const Box &A, const Triangle &tri, SubContact *out)
{
  if (tri.area2 <= 0.0) return 0;
  const double bound = A.bound;
  const double centre[3] = { A.c[0] - tri.a[0], A.c[1] - tri.a[1], A.c[2] - tri.a[2] };
  if (std::fabs(dot(centre, tri.unit)) >= bound) return 0;  // farther from the triangle's plane than the body reaches
  for (int i = 0; i < 3; i++)
    if (A.c[i] + bound <= tri.lo[i] || A.c[i] - bound >= tri.hi[i]) return 0;  // beside the triangle
  // the wall pushes towards the side the box's centre is on: a vertex driven past the plane (an
  // overlap beyond r) is pushed back, not through. While the centre itself is within r of the plane
  // that side is unsure (a box that wrapped round a wall's rim, where no vertex holds it, crosses the
  // plane beside the wall): past the plane nothing is pushed then, or the box would be thrown out.
  const double centre_height = dot(centre, tri.unit);
  const double side = centre_height < 0.0 ? -1.0 : 1.0;
  const bool deep = std::fabs(centre_height) > A.r;
  int n = 0;
  double p[3], q[3];
  for (int v = 0; v < 8; v++) {
    vertex(A, v, p);
    const double ap[3] = { p[0] - tri.a[0], p[1] - tri.a[1], p[2] - tri.a[2] };
    const double height = side * dot(ap, tri.unit);  // of the vertex above the plane, on the centre's side
    if (height >= A.r) continue;  // out of reach of the plane
    if (!projectOnTriangle(p, tri, q)) continue;
    const double d[3] = { p[0] - q[0], p[1] - q[1], p[2] - q[2] };
    double distance = height;
    double normal[3];
    if (height > 1e-12 * A.r) {
      distance = std::sqrt(dot(d, d));
      if (distance >= A.r) continue;
      for (int i = 0; i < 3; i++) normal[i] = d[i] / distance;
    } else {  // on or past the plane
      if (!deep) continue;
      for (int i = 0; i < 3; i++) normal[i] = side * tri.unit[i];
    }
    SubContact &s = out[n++];
    s.key = v;
    for (int i = 0; i < 3; i++) s.normal[i] = normal[i];
    s.overlap = A.r - distance;
    for (int i = 0; i < 3; i++) s.point[i] = q[i] - 0.5 * s.overlap * s.normal[i];
  }
  return n;
}

}  // namespace RoundedBox

#endif
