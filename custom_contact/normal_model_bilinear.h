/* Bilinear dissipative normal contact law (Richefeu, Mollon, Daudon, Villard 2012) for LIGGGHTS 3.8.
 *
 * Written for dem-orchestrator. Overlap h >= 0:
 *   loading   (h >= h_prev): f += k_n * (h - h_prev)        incremental, stiffness k_n (= k_n+)
 *   unloading (h <  h_prev): f  = e_n^2 * k_n * h           on the unloading line, k_n- = e_n^2 k_n+
 *   f is never negative; the history is reset when the contact is lost.
 * One impact then restores exactly e_n^2 of the normal kinetic energy, whatever the speed.
 * Tangential part: LIGGGHTS' `tangential history` with sidata.kt = k_t and no damping.
 * Per type-pair properties: kn, kt (as hooke/stiffness), coefficientRestitutionSquared.
 */
#ifdef NORMAL_MODEL
NORMAL_MODEL(BILINEAR,bilinear,40)
#else
#ifndef NORMAL_MODEL_BILINEAR_H_
#define NORMAL_MODEL_BILINEAR_H_

#include "contact_models.h"
#include "global_properties.h"
#include "normal_model_base.h"

namespace MODEL_PARAMS
{
  /* e_n^2 per type pair, within [0, 1]. */
  inline static MatrixProperty* createCoeffRestitutionSquared(PropertyRegistry & registry, const char * caller, bool sanity_checks)
  {
    return createPerTypePairProperty(registry, "coefficientRestitutionSquared", caller, sanity_checks, 0.0, 1.0);
  }
}

namespace LIGGGHTS {
namespace ContactModels
{
  template<>
  class NormalModel<BILINEAR> : public NormalModelBase
  {
  public:
    NormalModel(LAMMPS * lmp, IContactHistorySetup * hsetup, class ContactModelBase * c) :
      NormalModelBase(lmp, hsetup, c),
      k_n(NULL),
      k_t(NULL),
      en2(NULL)
    {
      // history[0] = normal force magnitude, history[1] = overlap at the previous step
      history_offset = hsetup->add_history_value("bilinear_force", "0");
      hsetup->add_history_value("bilinear_overlap", "0");
    }

    void registerSettings(Settings &) {}
    inline void postSettings(IContactHistorySetup *, ContactModelBase *) {}

    void connectToProperties(PropertyRegistry & registry)
    {
      registry.registerProperty("k_n", &MODEL_PARAMS::createKn);
      registry.registerProperty("k_t", &MODEL_PARAMS::createKt);
      registry.registerProperty("en2", &MODEL_PARAMS::createCoeffRestitutionSquared);
      registry.connect("k_n", k_n, "model bilinear");
      registry.connect("k_t", k_t, "model bilinear");
      registry.connect("en2", en2, "model bilinear");
      if (force->cg_active())
        error->cg(FLERR, "model bilinear");
    }

    inline double stressStrainExponent() { return 1.; }

    inline void surfacesIntersect(SurfacesIntersectData & sidata, ForceData & i_forces, ForceData & j_forces)
    {
      const int itype = sidata.itype;
      const int jtype = sidata.jtype;
      const double deltan = sidata.deltan;
      const double kn = k_n[itype][jtype] / force->nktv2p;
      const double kt = k_t[itype][jtype] / force->nktv2p;

      if (sidata.contact_flags) *sidata.contact_flags |= CONTACT_NORMAL_MODEL;
      double * const history = &sidata.contact_history[history_offset];
      const double previous_force = history[0];
      const double previous_overlap = history[1];

      double Fn;
      if (deltan >= previous_overlap)
        Fn = previous_force + kn * (deltan - previous_overlap);
      else
        Fn = en2[itype][jtype] * kn * deltan;
      if (Fn < 0.0) Fn = 0.0;

      if (sidata.computeflag && sidata.shearupdate)
      {
        history[0] = Fn;
        history[1] = deltan;
      }

      sidata.Fn = Fn;
      sidata.kn = kn;
      sidata.kt = kt;
      sidata.gamman = 0.0;
      sidata.gammat = 0.0;

      const double scale = sidata.is_wall ? sidata.area_ratio : 1.0;
      const double F[3] = { Fn * scale * sidata.en[0], Fn * scale * sidata.en[1], Fn * scale * sidata.en[2] };
      i_forces.delta_F[0] += F[0];
      i_forces.delta_F[1] += F[1];
      i_forces.delta_F[2] += F[2];
      if (!sidata.is_wall)
      {
        j_forces.delta_F[0] -= F[0];
        j_forces.delta_F[1] -= F[1];
        j_forces.delta_F[2] -= F[2];
      }
#ifdef NONSPHERICAL_ACTIVE_FLAG
      // A non-spherical body (superquadric) touches off its centre line: the normal force has a
      // moment about each centre, r x F with r from the centre to the contact point. Without it a
      // brick landing on a corner would never start to turn.
      if (sidata.is_non_spherical)
      {
        double r[3], torque[3];
        vectorSubtract3D(sidata.contact_point, atom->x[sidata.i], r);
        vectorCross3D(r, F, torque);
        i_forces.delta_torque[0] += torque[0];
        i_forces.delta_torque[1] += torque[1];
        i_forces.delta_torque[2] += torque[2];
        if (!sidata.is_wall)
        {
          vectorSubtract3D(sidata.contact_point, atom->x[sidata.j], r);
          vectorCross3D(r, F, torque);
          j_forces.delta_torque[0] -= torque[0];
          j_forces.delta_torque[1] -= torque[1];
          j_forces.delta_torque[2] -= torque[2];
        }
      }
#endif
    }

    inline void surfacesClose(SurfacesCloseData & scdata, ForceData &, ForceData &)
    {
      if (scdata.contact_flags) *scdata.contact_flags &= ~CONTACT_NORMAL_MODEL;
      double * const history = &scdata.contact_history[history_offset];
      history[0] = 0.0;
      history[1] = 0.0;
    }

    void beginPass(SurfacesIntersectData &, ForceData &, ForceData &) {}
    void endPass(SurfacesIntersectData &, ForceData &, ForceData &) {}

  protected:
    double ** k_n;
    double ** k_t;
    double ** en2;
    int history_offset;
  };
}
}

#endif // NORMAL_MODEL_BILINEAR_H_
#endif
