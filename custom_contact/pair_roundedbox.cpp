/* Rounded boxes touching rounded boxes: see pair_roundedbox.h. Written for dem-orchestrator. */
#include "pair_roundedbox.h"

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <string>
#include "atom.h"
#include "comm.h"
#include "error.h"
#include "fix_property_global.h"
#include "fix_roundedbox_history.h"
#include "force.h"
#include "memory.h"
#include "modify.h"
#include "neigh_list.h"
#include "neigh_request.h"
#include "neighbor.h"
#include "update.h"

using namespace LAMMPS_NS;
using namespace RoundedBox;

PairRoundedBox::PairRoundedBox(LAMMPS *lmp) : Pair(lmp), rounding_(-1.0), reach_(0.0), constants_(NULL), history_(NULL), skin_(0.0)
{
  single_enable = 0;
  restartinfo = 0;
  no_virial_fdotr_compute = 1;
}

PairRoundedBox::~PairRoundedBox()
{
  if (allocated) {
    memory->destroy(setflag);
    memory->destroy(cutsq);
  }
  if (constants_) {
    delete [] constants_[0];
    delete [] constants_;
  }
  if (history_ && modify->find_fix("roundedbox_history") >= 0) modify->delete_fix("roundedbox_history");
}

void PairRoundedBox::allocate()
{
  allocated = 1;
  const int n = atom->ntypes;
  memory->create(setflag, n + 1, n + 1, "pair:setflag");
  for (int i = 1; i <= n; i++)
    for (int j = i; j <= n; j++) setflag[i][j] = 0;
  memory->create(cutsq, n + 1, n + 1, "pair:cutsq");
}

void PairRoundedBox::settings(int narg, char **arg)
{
  if (narg != 2 || strcmp(arg[0], "rounding") != 0)
    error->all(FLERR, "Illegal pair_style roundedbox command: expected `pair_style roundedbox rounding R` (R in m)");
  rounding_ = force->numeric(FLERR, arg[1]);
  if (rounding_ <= 0.0) error->all(FLERR, "pair_style roundedbox: the rounding R must be > 0 (m)");
  // a pair lists its features within the reach (2 R) plus R / 5: on a packed slab of the study's
  // bricks (R = 1 mm) 0.1 and 0.2 mm were fastest, 0.05 and 0.5 mm 5 to 10 % slower
  skin_ = 0.2 * rounding_;
}

void PairRoundedBox::coeff(int narg, char **arg)
{
  if (narg != 2) error->all(FLERR, "Incorrect args for pair coefficients: pair_coeff * * (the constants come from fix property/global)");
  if (!allocated) allocate();
  int ilo, ihi, jlo, jhi;
  force->bounds(arg[0], atom->ntypes, ilo, ihi);
  force->bounds(arg[1], atom->ntypes, jlo, jhi);
  for (int i = ilo; i <= ihi; i++)
    for (int j = MAX(jlo, i); j <= jhi; j++) setflag[i][j] = 1;
}

void PairRoundedBox::read_constants(LAMMPS *lmp, const char *caller, int ntypes, Constants **&table)
{
  const char *names[4] = { "kn", "kt", "coefficientRestitutionSquared", "coefficientFriction" };
  FixPropertyGlobal *fixes[4];
  for (int p = 0; p < 4; p++)
    fixes[p] = static_cast<FixPropertyGlobal *>(lmp->modify->find_fix_property(names[p], "property/global", "peratomtypepair", ntypes, ntypes, caller));
  if (!table) {
    table = new Constants *[ntypes + 1];
    table[0] = new Constants[(ntypes + 1) * (ntypes + 1)];
    for (int i = 1; i <= ntypes; i++) table[i] = table[0] + i * (ntypes + 1);
  }
  for (int i = 1; i <= ntypes; i++)
    for (int j = 1; j <= ntypes; j++) {
      Constants &k = table[i][j];
      k.kn = fixes[0]->compute_array(i - 1, j - 1);
      k.kt = fixes[1]->compute_array(i - 1, j - 1);
      k.en2 = fixes[2]->compute_array(i - 1, j - 1);
      k.mu = fixes[3]->compute_array(i - 1, j - 1);
      if (k.kn <= 0.0 || k.kt < 0.0 || k.en2 < 0.0 || k.en2 > 1.0 || k.mu < 0.0)
        lmp->error->all(FLERR, "roundedbox: kn must be > 0, kt >= 0, coefficientRestitutionSquared in [0, 1], coefficientFriction >= 0");
    }
}

void PairRoundedBox::body(Atom *atom, int i, double rounding, Box &box)
{
  for (int k = 0; k < 3; k++) {
    box.c[k] = atom->x[i][k];
    box.h[k] = atom->shape[i][k] - rounding;
  }
  quaternionToMatrix(atom->quaternion[i], box.R);
  box.r = rounding;
  box.bound = std::sqrt(dot(box.h, box.h)) + rounding;
}

void PairRoundedBox::init_style()
{
  if (!atom->superquadric_flag)
    error->all(FLERR, "pair_style roundedbox needs atom_style superquadric (shape: the outer half extents; quaternion: the orientation)");
  if (force->newton_pair) error->all(FLERR, "pair_style roundedbox needs newton off");
  if (!comm->ghost_velocity) error->all(FLERR, "pair_style roundedbox needs `communicate single vel yes`");
  read_constants(lmp, "pair roundedbox", atom->ntypes, constants_);

  // the largest body sets the neighbour cut-off; every body must be thicker than its rounding
  double reach = 0.0, thinnest = 1e300;
  for (int i = 0; i < atom->nlocal; i++) {
    const double *s = atom->shape[i];
    reach = MAX(reach, std::sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]));
    thinnest = MIN(thinnest, MIN(s[0], MIN(s[1], s[2])));
  }
  MPI_Allreduce(&reach, &reach_, 1, MPI_DOUBLE, MPI_MAX, world);
  double thinnest_all;
  MPI_Allreduce(&thinnest, &thinnest_all, 1, MPI_DOUBLE, MPI_MIN, world);
  if (thinnest_all < rounding_)
    error->all(FLERR, "pair_style roundedbox: a body's half extent is smaller than the rounding R");

  int request = neighbor->request(this);
  neighbor->requests[request]->half = 1;
  neighbor->requests[request]->full = 0;

  if (!history_) {
    const int index = modify->find_fix("roundedbox_history");
    if (index >= 0) history_ = static_cast<FixRoundedBoxHistory *>(modify->fix[index]);
    else {
      char *fixarg[3] = { (char *) "roundedbox_history", (char *) "all", (char *) "roundedbox/history" };
      modify->add_fix(3, fixarg);
      history_ = static_cast<FixRoundedBoxHistory *>(modify->fix[modify->find_fix("roundedbox_history")]);
    }
  }
}

double PairRoundedBox::init_one(int, int)
{
  return 2.0 * reach_;
}

void PairRoundedBox::track_motion(int nall, bool rebuilt)
{
  double **x = atom->x, **q = atom->quaternion;
  if (static_cast<int>(travel_.size()) < nall) {
    travel_.resize(nall);
    step_.resize(nall);
    last_x_.resize(3 * nall);
    last_q_.resize(4 * nall);
  }
  for (int i = 0; i < nall; i++) {
    double *lx = &last_x_[3 * i], *lq = &last_q_[4 * i];
    if (rebuilt) travel_[i] = 0.0;  // step_ keeps the last step's: how fast the body moves
    else {
      // a point at distance rho from the centre moves by at most |dx| + 2 rho min(|q - q'|, |q + q'|)
      // under a rotation from unit quaternion q' to q (its chord is 2 rho sin(angle / 2))
      double dx = 0.0, minus = 0.0, plus = 0.0;
      for (int k = 0; k < 3; k++) dx += (x[i][k] - lx[k]) * (x[i][k] - lx[k]);
      for (int k = 0; k < 4; k++) {
        minus += (q[i][k] - lq[k]) * (q[i][k] - lq[k]);
        plus += (q[i][k] + lq[k]) * (q[i][k] + lq[k]);
      }
      const double moved = std::sqrt(dx) + 2.0 * boxes_[i].bound * std::sqrt(MIN(minus, plus));
      step_[i] = moved * (1.0 + 1e-6) + 1e-15;
      travel_[i] += step_[i];
    }
    for (int k = 0; k < 3; k++) lx[k] = x[i][k];
    for (int k = 0; k < 4; k++) lq[k] = q[i][k];
  }
}

void PairRoundedBox::compute(int eflag, int vflag)
{
  if (eflag || vflag) ev_setup(eflag, vflag);
  else evflag = vflag_fdotr = 0;

  double **x = atom->x, **v = atom->v, **omega = atom->omega, **f = atom->f, **torque = atom->torque;
  int *type = atom->type, *tag = atom->tag, *mask = atom->mask;
  const int nlocal = atom->nlocal;
  const double dt = update->dt;
  // set-ups (run starts, `run 0`) recompute forces from the kept history without changing it
  const bool keep = !update->setupflag;
  (void) mask;

  history_->begin(nlocal);
  // every body as a box once (orientation matrix, bounding radius), not once per neighbour
  const int nall = nlocal + atom->nghost;
  if (static_cast<int>(boxes_.size()) < nall) boxes_.resize(nall);
  for (int i = 0; i < nall; i++) body(atom, i, rounding_, boxes_[i]);
  int entries = 0;
  for (int ii = 0; ii < list->inum; ii++) entries += list->numneigh[list->ilist[ii]];
  const bool rebuilt = neighbor->ago == 0 || static_cast<int>(entries_.size()) != entries;
  track_motion(nall, rebuilt);
  if (rebuilt) {
    const Entry unknown = { -1.0, 0.0, 0.0, -1, false };
    entries_.assign(entries, unknown);
    lists_.clear();
  }
  SubContact sub[MAX_PAIR];
  History next;
  int entry = 0;
  for (int ii = 0; ii < list->inum; ii++) {
    const int i = list->ilist[ii];
    const int *neighbours = list->firstneigh[i];
    for (int jj = 0; jj < list->numneigh[i]; jj++, entry++) {
      const int j = neighbours[jj] & NEIGHMASK;
      Entry &known = entries_[entry];
      const double travelled = travel_[i] + travel_[j];
      // still apart: their travels since they were last parted cannot have closed the distance
      if (known.apart > travelled - known.travel) continue;
      // A is the lower tag: the same pair gives the same numbers on every process
      const bool i_first = tag[i] < tag[j];
      const int a = i_first ? i : j, b = i_first ? j : i;
      int n;
      if (known.listed && travelled - known.travel < known.skin)
        n = candidateContacts(boxes_[a], boxes_[b], &lists_[known.list + 1], lists_[known.list], sub);
      else {
        known.travel = travelled;
        known.listed = false;
        const double apart = boxesApart(boxes_[a], boxes_[b]);
        // 1e-12 m below it: the distance is found to round-off of coordinates of a few metres
        known.apart = apart > 0.0 ? apart - 1e-12 : -1.0;
        if (apart > 0.0) continue;
        if (known.list < 0) {
          known.list = static_cast<int>(lists_.size());
          lists_.resize(lists_.size() + 1 + MAX_CANDIDATES);
        }
        unsigned char *listed = &lists_[known.list];
        // a skin the pair takes about LIST_STEPS steps to cross at its last step's pace, at least skin_,
        // at most the reach (a wider one lists features that touch nothing for long)
        known.skin = std::min(2.0 * rounding_, std::max(skin_, LIST_STEPS * (step_[i] + step_[j])));
        const int count = candidates(boxes_[a], boxes_[b], known.skin, listed + 1);
        known.listed = count >= 0;
        listed[0] = static_cast<unsigned char>(known.listed ? count : 0);
        n = known.listed ? candidateContacts(boxes_[a], boxes_[b], listed + 1, count, sub) : boxBoxContacts(boxes_[a], boxes_[b], sub);
      }
      if (!n) continue;
      const Constants &k = constants_[type[a]][type[b]];
      const bool j_local = j < nlocal;
      double total[3] = { 0.0, 0.0, 0.0 }, torque_a[3] = { 0.0, 0.0, 0.0 }, torque_b[3] = { 0.0, 0.0, 0.0 };
      const double partner = static_cast<double>(tag[j]);
      const FixRoundedBoxHistory::Slot *slot, *slots_end;  // i's slots with j, walked as the keys rise
      history_->partner_slots(i, partner, slot, slots_end);
      for (int s = 0; s < n; s++) {
        const SubContact &c = sub[s];
        double ra[3], rb[3], wa[3], wb[3], relative[3], force[3], moment[3];
        for (int m = 0; m < 3; m++) { ra[m] = c.point[m] - x[a][m]; rb[m] = c.point[m] - x[b][m]; }
        cross(omega[a], ra, wa);
        cross(omega[b], rb, wb);
        for (int m = 0; m < 3; m++) relative[m] = v[a][m] + wa[m] - v[b][m] - wb[m];
        while (slot != slots_end && slot->key < c.key) slot++;
        const History *previous = slot != slots_end && slot->key == c.key ? &slot->history : NULL;
        subContactForce(c, relative, k, dt, previous, next, force);
        if (keep) {
          history_->store(i, partner, c.key, next);
          if (j_local) history_->store(j, static_cast<double>(tag[i]), c.key, next);
        }
        for (int m = 0; m < 3; m++) total[m] += force[m];
        cross(ra, force, moment);
        for (int m = 0; m < 3; m++) torque_a[m] += moment[m];
        cross(rb, force, moment);
        for (int m = 0; m < 3; m++) torque_b[m] -= moment[m];
      }
      // forces on local bodies only (newton off: the process owning a ghost computes the pair too)
      if (a < nlocal) for (int m = 0; m < 3; m++) { f[a][m] += total[m]; torque[a][m] += torque_a[m]; }
      if (b < nlocal) for (int m = 0; m < 3; m++) { f[b][m] -= total[m]; torque[b][m] += torque_b[m]; }
    }
  }
  if (keep) history_->commit(nlocal);
}
