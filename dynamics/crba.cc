#include "dynamics/crba.h"

namespace hyq::dynamics {

void Crba(const Model& model, const Kinematics& kin, CrbaWorkspace* ws, MatrixV* M) {
  // backward pass, all in W: Ic[parent] += Ic[child]
  ws->Ic_W = kin.I_W;
  for (int i = kNumBodies - 1; i > 0; --i) ws->Ic_W[model.bodies[i].parent] += ws->Ic_W[i];

  M->setZero();
  // leg dofs: F = Ic_b S_i, then M(d, i) = S_dᵀ F up the chain and into the base   (1)
  for (int b = 1; b < kNumBodies; ++b) {
    const int i = VIndexOfJoint(b - 1);
    const Vector6d F = ws->Ic_W[b] * kin.S_W.col(i);
    for (int k = b; k != kTrunk; k = model.bodies[k].parent) {
      const int d = VIndexOfJoint(k - 1);
      (*M)(d, i) = (*M)(i, d) = kin.S_W.col(d).dot(F);
    }
    for (int d = 0; d < kNumBaseDofs; ++d) (*M)(d, i) = (*M)(i, d) = kin.S_W.col(d).dot(F);
  }
  // base block: all six dofs share the trunk's composite inertia
  for (int c = 0; c < kNumBaseDofs; ++c) {
    const Vector6d F = ws->Ic_W[kTrunk] * kin.S_W.col(c);
    for (int d = 0; d <= c; ++d) (*M)(d, c) = (*M)(c, d) = kin.S_W.col(d).dot(F);
  }
}

}  // namespace hyq::dynamics
