/* Rounded boxes against mesh walls (fix mesh/surface), for LIGGGHTS 3.8.
 *
 * Written for dem-orchestrator:
 *   fix ID group wall/roundedbox rounding R n_meshes N meshes MESH1 ... MESHN
 * Each vertex of a body's inner box over a wall triangle, within R of its plane, is a contact
 * point with the law of roundedbox_law.h (wall side: the mesh's type in the same property/global
 * matrices as pair roundedbox). Walls do not move. A vertex over a seam between two coplanar
 * triangles touches the wall once; in a crease between two walls it touches both. The histories
 * live in a fix roundedbox/history (ID: this fix's ID + "_history"), which unfixing this fix removes.
 */
#ifdef FIX_CLASS

FixStyle(wall/roundedbox,FixWallRoundedBox)

#else

#ifndef DEMORCH_FIX_WALL_ROUNDEDBOX_H
#define DEMORCH_FIX_WALL_ROUNDEDBOX_H

#include <string>
#include <vector>
#include "fix.h"
#include "roundedbox_law.h"

namespace LAMMPS_NS {

class FixWallRoundedBox : public Fix {
 public:
  FixWallRoundedBox(class LAMMPS *, int, char **);
  ~FixWallRoundedBox();
  int setmask();
  void post_create();
  void pre_delete(bool);
  void init();
  void setup(int);
  void post_force(int);

 private:
  double rounding_;
  std::vector<std::string> mesh_ids_;
  std::vector<class FixMeshSurface *> meshes_;
  std::vector<double> mesh_codes_;  // 20-bit hash of each mesh's fix ID (djb2)
  struct WallTriangle {
    RoundedBox::Triangle triangle;
    double partner;  // the mesh's code * 2^32 + the triangle's id
    int type;        // the mesh's atom type
  };
  std::vector<WallTriangle> triangles_;  // every mesh's local and ghost triangles, remade each step
  RoundedBox::Constants **constants_;
  class FixRoundedBoxHistory *history_;
  std::string history_id_;
};

}

#endif
#endif
