#include "dynamics/rnea.h"

namespace hyq::dynamics {
namespace {

// shared body of InverseDynamics and BiasForces; vdot == nullptr means v̇ = 0
void Rnea(const Model& model, const Kinematics& kin, const VectorV* vdot, RneaWorkspace* ws,
          VectorV* tau) {
  Vector6d minus_g;  // the base accelerates upwards instead of gravity pulling down
  minus_g << Eigen::Vector3d::Zero(), -model.gravity_W;

  // forward pass: acceleration from v̇ (when given) on top of the velocity products
  std::array<Vector6d, kNumBodies> A_vdot;
  A_vdot[kTrunk].setZero();
  if (vdot != nullptr) A_vdot[kTrunk] = kin.S_W.leftCols<kNumBaseDofs>() * vdot->head<6>();
  for (int i = 0; i < kNumBodies; ++i) {
    if (i > 0) {
      A_vdot[i] = A_vdot[model.bodies[i].parent];
      if (vdot != nullptr) {
        const int d = VIndexOfJoint(i - 1);
        A_vdot[i] += kin.S_W.col(d) * (*vdot)(d);
      }
    }
    const Vector6d A = kin.A_vp_WB[i] + A_vdot[i] + minus_g;
    // F_i = I_i A_i + V_i ×* I_i V_i
    ws->F_W[i] = kin.I_W[i] * A + CrossForce(kin.V_WB[i], kin.I_W[i] * kin.V_WB[i]);
  }

  // backward pass: accumulate into parents, project on the joint axes
  for (int i = kNumBodies - 1; i > 0; --i) {
    const int d = VIndexOfJoint(i - 1);
    (*tau)(d) = kin.S_W.col(d).dot(ws->F_W[i]);
    ws->F_W[model.bodies[i].parent] += ws->F_W[i];
  }
  tau->head<kNumBaseDofs>() = kin.S_W.leftCols<kNumBaseDofs>().transpose() * ws->F_W[kTrunk];
}

}  // namespace

void InverseDynamics(const Model& model, const Kinematics& kin, const VectorV& vdot,
                     RneaWorkspace* ws, VectorV* tau) {
  Rnea(model, kin, &vdot, ws, tau);
}

void BiasForces(const Model& model, const Kinematics& kin, RneaWorkspace* ws, VectorV* h) {
  Rnea(model, kin, nullptr, ws, h);
}

}  // namespace hyq::dynamics
