#include "dynamics/cycle_dynamics.h"

namespace hyq::dynamics {

const char* ToString(DynamicsStatus s) {
  switch (s) {
    case DynamicsStatus::kOk: return "ok";
    case DynamicsStatus::kBadInput: return "bad_input";
    case DynamicsStatus::kNotPositiveDefinite: return "not_positive_definite";
  }
  return "unknown";
}

DynamicsStatus ComputeCycleDynamics(const Model& model, const VectorQ& q, const VectorV& v,
                                    CycleDynamics* out) {
  if (!q.allFinite() || !v.allFinite() || q.segment<4>(3).squaredNorm() < 1e-12)
    return DynamicsStatus::kBadInput;
  ForwardKinematics(model, q, v, &out->kin);
  ComputeFootKinematics(model, out->kin, &out->feet);
  Crba(model, out->kin, &out->crba_ws, &out->M);
  BiasForces(model, out->kin, &out->rnea_ws, &out->bias);
  if (FactorMassMatrix(out->M, &out->factor) != FactorStatus::kOk)
    return DynamicsStatus::kNotPositiveDefinite;
  ComputeInverseBlocks(out->M, out->factor, &out->inv);
  return DynamicsStatus::kOk;
}

}  // namespace hyq::dynamics
