#include "dynamics/kinematics.h"

#include <cmath>

#include <Eigen/Geometry>

namespace hyq::dynamics {
namespace {

// Rodrigues: rotation by angle about unit axis a.
Eigen::Matrix3d AxisRotation(const Eigen::Vector3d& a, double angle) {
  const double s = std::sin(angle);
  const double c = std::cos(angle);
  const double t = 1.0 - c;
  Eigen::Matrix3d R;
  R << t * a.x() * a.x() + c, t * a.x() * a.y() - s * a.z(), t * a.x() * a.z() + s * a.y(),
      t * a.x() * a.y() + s * a.z(), t * a.y() * a.y() + c, t * a.y() * a.z() - s * a.x(),
      t * a.x() * a.z() - s * a.y(), t * a.y() * a.z() + s * a.x(), t * a.z() * a.z() + c;
  return R;
}

}  // namespace

void ForwardKinematics(const Model& model, const VectorQ& q, const VectorV& v, Kinematics* kin) {
  // trunk pose from the free joint
  const Eigen::Quaterniond quat = Eigen::Quaterniond(q(3), q(4), q(5), q(6)).normalized();
  const Eigen::Matrix3d& R = kin->R_WB[kTrunk] = quat.toRotationMatrix();
  const Eigen::Vector3d& p = kin->p_WB_W[kTrunk] = q.head<3>();

  // base motion subspace: world translations, then rotations about base axes through p
  for (int k = 0; k < 3; ++k) {
    kin->S_W.col(k) << Eigen::Vector3d::Zero(), Eigen::Vector3d::Unit(k);
    kin->S_W.col(3 + k) << R.col(k), p.cross(R.col(k));
  }
  const Eigen::Vector3d w_W = R * v.segment<3>(3);
  const Eigen::Vector3d v_B = v.head<3>();
  kin->V_WB[kTrunk] << w_W, v_B + p.cross(w_W);
  // Ṡ_base v_base = V ×m (S_rot w) = [0; v_B × w_W]  (translation axes are fixed in W)
  kin->A_vp_WB[kTrunk] << Eigen::Vector3d::Zero(), v_B.cross(w_W);
  kin->I_W[kTrunk] = ToWorld(model.bodies[kTrunk].inertia, R, p);

  // legs, parents before children
  for (int i = 1; i < kNumBodies; ++i) {
    const Body& body = model.bodies[i];
    const int parent = body.parent;
    const int dof = VIndexOfJoint(i - 1);
    const Eigen::Matrix3d R_WJ = kin->R_WB[parent] * body.R_PJ;
    kin->R_WB[i].noalias() = R_WJ * AxisRotation(body.axis_B, q(dof + 1));
    kin->p_WB_W[i] = kin->p_WB_W[parent] + kin->R_WB[parent] * body.p_PJ_P;
    const Eigen::Vector3d a = R_WJ * body.axis_B;
    kin->S_W.col(dof) << a, kin->p_WB_W[i].cross(a);
    const Vector6d Sv = kin->S_W.col(dof) * v(dof);
    kin->V_WB[i] = kin->V_WB[parent] + Sv;
    // A_i = A_parent + V_i ×m S_i q̇_i   (Featherstone eq 5.7, world frame)
    kin->A_vp_WB[i] = kin->A_vp_WB[parent] + CrossMotion(kin->V_WB[i], Sv);
    kin->I_W[i] = ToWorld(body.inertia, kin->R_WB[i], kin->p_WB_W[i]);
  }
}

void ComputeFootKinematics(const Model& model, const Kinematics& kin, FootKinematics* feet) {
  for (int f = 0; f < kNumFeet; ++f) {
    const FootFrame& foot = model.feet[f];
    const int b = foot.body;
    const Eigen::Vector3d p_WF = kin.p_WB_W[b] + kin.R_WB[b] * foot.p_BF_B;
    feet->p_WF_W[f] = p_WF;

    // v = v_O + w × p;  a = a_O + ẇ × p + w × v   (classical acceleration of a body point)
    const auto w = kin.V_WB[b].head<3>();
    const Eigen::Vector3d v_WF = kin.V_WB[b].tail<3>() + w.cross(p_WF);
    feet->v_WF_W[f] = v_WF;
    feet->Jdot_v_W[f] = kin.A_vp_WB[b].tail<3>() + kin.A_vp_WB[b].head<3>().cross(p_WF) +
                        w.cross(v_WF);
    feet->Jwdot_v_W[f] = kin.A_vp_WB[b].head<3>();

    // J(:, d) = S_lin(d) + S_ang(d) × p for the ancestors of the foot's body
    // Jw(:, d) = S_ang(d) for the same dofs
    FootJacobian& J = feet->J_WF[f];
    FootJacobian& Jw = feet->Jw_WF[f];
    J.setZero();
    Jw.setZero();
    for (int d = 0; d < kNumBaseDofs; ++d) {
      J.col(d) = kin.S_W.col(d).tail<3>() + kin.S_W.col(d).head<3>().cross(p_WF);
      Jw.col(d) = kin.S_W.col(d).head<3>();
    }
    for (int k = b; k != kTrunk; k = model.bodies[k].parent) {
      const int d = VIndexOfJoint(k - 1);
      J.col(d) = kin.S_W.col(d).tail<3>() + kin.S_W.col(d).head<3>().cross(p_WF);
      Jw.col(d) = kin.S_W.col(d).head<3>();
    }
  }
}

void ContactPointJacobian(const Model& model, const FootKinematics& feet, int f,
                          const Eigen::Vector3d& n_W, FootJacobian* J_c,
                          Eigen::Vector3d* Jdot_c_v) {
  const double r = model.feet[f].radius_m;
  // v_c = v_F + w × (−r n) = v_F + r n × w
  J_c->noalias() = feet.J_WF[f] + r * Skew(n_W) * feet.Jw_WF[f];
  *Jdot_c_v = feet.Jdot_v_W[f] + r * n_W.cross(feet.Jwdot_v_W[f]);
}

}  // namespace hyq::dynamics
