/* Rounded boxes against mesh walls: see fix_wall_roundedbox.h. Written for dem-orchestrator. */
#include "fix_wall_roundedbox.h"

#include <algorithm>
#include <cstring>
#include "atom.h"
#include "error.h"
#include "fix_mesh_surface.h"
#include "fix_roundedbox_history.h"
#include "force.h"
#include "group.h"
#include "modify.h"
#include "pair_roundedbox.h"
#include "tri_mesh.h"
#include "update.h"

using namespace LAMMPS_NS;
using namespace FixConst;
using namespace RoundedBox;

namespace {
struct WallContact {
  SubContact contact;
  double partner;  // the mesh's code * 2^32 + the triangle's id
  int type;        // the mesh's atom type
};
bool before(const WallContact &p, const WallContact &q)
{
  return p.contact.key != q.contact.key ? p.contact.key < q.contact.key : p.partner < q.partner;
}
}

FixWallRoundedBox::FixWallRoundedBox(LAMMPS *lmp, int narg, char **arg) :
  Fix(lmp, narg, arg), rounding_(-1.0), constants_(NULL), history_(NULL)
{
  // fix ID group wall/roundedbox rounding R n_meshes N meshes M1 ... MN
  if (narg < 8 || strcmp(arg[3], "rounding") != 0 || strcmp(arg[5], "n_meshes") != 0 || strcmp(arg[7], "meshes") != 0)
    error->all(FLERR, "Illegal fix wall/roundedbox command: expected `rounding R n_meshes N meshes M1 ... MN`");
  rounding_ = force->numeric(FLERR, arg[4]);
  if (rounding_ <= 0.0) error->all(FLERR, "fix wall/roundedbox: the rounding R must be > 0 (m)");
  const int n = force->inumeric(FLERR, arg[6]);
  if (n < 1 || narg != 8 + n) error->all(FLERR, "fix wall/roundedbox: n_meshes must be >= 1 and match the meshes listed");
  for (int m = 0; m < n; m++) mesh_ids_.push_back(arg[8 + m]);
  history_id_ = std::string(id) + "_history";
}

FixWallRoundedBox::~FixWallRoundedBox()
{
  if (constants_) {
    delete [] constants_[0];
    delete [] constants_;
  }
}

void FixWallRoundedBox::pre_delete(bool unfixflag)
{
  // unfixing the walls ends their contacts' histories (LIGGGHTS' fix wall/gran does the same)
  if (unfixflag && modify->find_fix(history_id_.c_str()) >= 0) modify->delete_fix(history_id_.c_str());
}

int FixWallRoundedBox::setmask()
{
  return POST_FORCE;
}

void FixWallRoundedBox::post_create()
{
  // created here, under a fixed ID, so that a restart file's histories find their way back to it
  if (modify->find_fix(history_id_.c_str()) < 0) {
    char *fixarg[3] = { (char *) history_id_.c_str(), group->names[igroup], (char *) "roundedbox/history" };
    modify->add_fix(3, fixarg);
  }
  history_ = static_cast<FixRoundedBoxHistory *>(modify->fix[modify->find_fix(history_id_.c_str())]);
}

void FixWallRoundedBox::init()
{
  if (!atom->superquadric_flag) error->all(FLERR, "fix wall/roundedbox needs atom_style superquadric");
  meshes_.clear();
  mesh_codes_.clear();
  for (size_t m = 0; m < mesh_ids_.size(); m++) {
    const int index = modify->find_fix(mesh_ids_[m].c_str());
    FixMeshSurface *mesh = index >= 0 ? dynamic_cast<FixMeshSurface *>(modify->fix[index]) : NULL;
    if (!mesh) error->all(FLERR, (std::string("fix wall/roundedbox: no fix mesh/surface with ID ") + mesh_ids_[m]).c_str());
    meshes_.push_back(mesh);
    // the mesh's code: from its fix ID, so that a history read back from a restart file goes to the
    // wall of the same name whatever its place in this fix's list (a release's walls are not its packing's)
    unsigned long code = 5381;
    for (const char *c = mesh_ids_[m].c_str(); *c; c++) code = (code * 33u + static_cast<unsigned char>(*c)) & 0xFFFFFu;
    mesh_codes_.push_back(static_cast<double>(code));
  }
  PairRoundedBox::read_constants(lmp, "fix wall/roundedbox", atom->ntypes, constants_);
  history_ = static_cast<FixRoundedBoxHistory *>(modify->fix[modify->find_fix(history_id_.c_str())]);
}

void FixWallRoundedBox::setup(int vflag)
{
  post_force(vflag);
}

void FixWallRoundedBox::post_force(int)
{
  double **x = atom->x, **v = atom->v, **omega = atom->omega, **f = atom->f, **torque = atom->torque;
  const int *mask = atom->mask, *type = atom->type;
  const int nlocal = atom->nlocal;
  const double dt = update->dt;
  const bool keep = !update->setupflag;

  history_->begin(nlocal);
  // the walls' triangles, each once a step (their planes and bounds), not once per body
  triangles_.clear();
  for (size_t m = 0; m < meshes_.size(); m++) {
    TriMesh *mesh = meshes_[m]->triMesh();
    const int triangles = mesh->sizeLocal() + mesh->sizeGhost();
    for (int t = 0; t < triangles; t++) {
      double a[3], b[3], c[3];
      mesh->node(t, 0, a);
      mesh->node(t, 1, b);
      mesh->node(t, 2, c);
      WallTriangle w;
      triangle(a, b, c, w.triangle);
      w.partner = mesh_codes_[m] * 4294967296.0 + static_cast<double>(mesh->id(t));
      w.type = meshes_[m]->atomTypeWall();
      triangles_.push_back(w);
    }
  }
  std::vector<WallContact> found;
  SubContact sub[MAX_WALL];
  Box box;
  History next;
  for (int i = 0; i < nlocal; i++) {
    if (!(mask[i] & groupbit)) continue;
    PairRoundedBox::body(atom, i, rounding_, box);
    found.clear();
    for (size_t t = 0; t < triangles_.size(); t++) {
      const int n = boxTriangleContacts(box, triangles_[t].triangle, sub);
      for (int s = 0; s < n; s++) {
        WallContact w;
        w.contact = sub[s];
        w.partner = triangles_[t].partner;
        w.type = triangles_[t].type;
        found.push_back(w);
      }
    }
    // one contact per vertex and plane: coplanar triangles sharing the vertex's spot keep the lowest
    std::sort(found.begin(), found.end(), before);
    for (size_t p = 0; p < found.size(); p++) {
      const WallContact &w = found[p];
      bool repeated = false;
      for (size_t q = 0; q < p && !repeated; q++)
        repeated = found[q].contact.key == w.contact.key && dot(found[q].contact.normal, w.contact.normal) > 1.0 - 1e-9;
      if (repeated) continue;
      const SubContact &c = w.contact;
      double r[3], spin[3], relative[3], force[3], moment[3];
      for (int k = 0; k < 3; k++) r[k] = c.point[k] - x[i][k];
      cross(omega[i], r, spin);
      for (int k = 0; k < 3; k++) relative[k] = v[i][k] + spin[k];
      subContactForce(c, relative, constants_[type[i]][w.type], dt, history_->find(i, w.partner, c.key), next, force);
      if (keep) history_->store(i, w.partner, c.key, next);
      cross(r, force, moment);
      for (int k = 0; k < 3; k++) { f[i][k] += force[k]; torque[i][k] += moment[k]; }
    }
  }
  if (keep) history_->commit(nlocal);
}
