// The only file that sees urdfdom and tinyxml2.
#include "dynamics/urdf_loader.h"

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <tinyxml2.h>
#include <urdf_parser/urdf_parser.h>

namespace hyq::dynamics {
namespace {

[[noreturn]] void Fail(const std::string& source, const std::string& what) {
  throw ModelError(source + ": " + what);
}

std::string Num(double x) {
  std::ostringstream s;
  s.precision(6);
  s << x;
  return s.str();
}

Eigen::Matrix3d ToMatrix(const urdf::Rotation& r) {
  return Eigen::Quaterniond(r.w, r.x, r.y, r.z).normalized().toRotationMatrix();
}
Eigen::Vector3d ToVector(const urdf::Vector3& v) { return {v.x, v.y, v.z}; }

/// A link's own inertial, in the link frame (zero mass when it has none).
RigidBodyInertia LinkInertia(const urdf::Link& link) {
  RigidBodyInertia out;
  if (!link.inertial) return out;
  const urdf::Inertial& in = *link.inertial;
  const Eigen::Matrix3d R = ToMatrix(in.origin.rotation);
  Eigen::Matrix3d I;
  I << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
  out.mass = in.mass;
  out.p_BoBcm_B = ToVector(in.origin.position);
  out.I_Bcm_B = R * I * R.transpose();
  return out;
}

/// Adds b (given in a frame placed at (R, p) in a's frame) to a: masses, COM, parallel axis.
void Lump(RigidBodyInertia* a, const RigidBodyInertia& b, const Eigen::Matrix3d& R,
          const Eigen::Vector3d& p) {
  if (b.mass <= 0.0) return;
  const Eigen::Vector3d cb = p + R * b.p_BoBcm_B;
  const double m = a->mass + b.mass;
  const Eigen::Vector3d c = (a->mass * a->p_BoBcm_B + b.mass * cb) / m;
  auto shift = [](double mass, const Eigen::Vector3d& d) {
    return mass * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose());
  };
  a->I_Bcm_B = a->I_Bcm_B + shift(a->mass, a->p_BoBcm_B - c) + R * b.I_Bcm_B * R.transpose() +
               shift(b.mass, cb - c);
  a->mass = m;
  a->p_BoBcm_B = c;
}

struct FixedChild {
  const urdf::Link* link;
  Eigen::Matrix3d R;  // in the moving ancestor's frame
  Eigen::Vector3d p;
};

/// All links hanging from `link` through fixed joints only, with their placement in its frame.
void CollectFixed(const urdf::Link& link, const Eigen::Matrix3d& R, const Eigen::Vector3d& p,
                  std::vector<FixedChild>* out) {
  for (const auto& j : link.child_joints) {
    if (j->type != urdf::Joint::FIXED) continue;
    for (const auto& c : link.child_links) {
      if (c->parent_joint != j) continue;
      const Eigen::Matrix3d Rc = R * ToMatrix(j->parent_to_joint_origin_transform.rotation);
      const Eigen::Vector3d pc = p + R * ToVector(j->parent_to_joint_origin_transform.position);
      out->push_back({c.get(), Rc, pc});
      CollectFixed(*c, Rc, pc, out);
    }
  }
}

void CheckInertia(const std::string& source, const std::string& link,
                  const RigidBodyInertia& in) {
  if (!(in.mass > 0.0) || !std::isfinite(in.mass))
    Fail(source, "link '" + link + "': expected a positive mass, found " + Num(in.mass));
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(in.I_Bcm_B);
  const Eigen::Vector3d ev = eig.eigenvalues();
  if (!in.I_Bcm_B.allFinite() || !(ev.minCoeff() > 0.0))
    Fail(source, "link '" + link +
                     "': expected a positive definite inertia (with fixed children lumped in), "
                     "found eigenvalues " +
                     Num(ev(0)) + ", " + Num(ev(1)) + ", " + Num(ev(2)));
  // A physical inertia also satisfies the triangle inequalities on its principal moments.
  if (ev(0) + ev(1) < ev(2) * (1.0 - 1e-9))
    Fail(source, "link '" + link + "': principal moments " + Num(ev(0)) + ", " + Num(ev(1)) +
                     ", " + Num(ev(2)) + " violate the triangle inequality (not a rigid body)");
}

void ReadPosture(const tinyxml2::XMLDocument& doc, const std::string& source,
                 const std::array<std::string, kNumJoints>& names, Model* model) {
  const tinyxml2::XMLElement* robot = doc.FirstChildElement("robot");
  const tinyxml2::XMLElement* posture = nullptr;
  for (auto* e = robot->FirstChildElement("hyq_posture"); e != nullptr;
       e = e->NextSiblingElement("hyq_posture")) {
    const char* n = e->Attribute("name");
    if (n != nullptr && std::string(n) == "standing") posture = e;
  }
  if (posture == nullptr)
    Fail(source, "expected a <hyq_posture name=\"standing\" base_height=\"..\"> element, found none");
  if (posture->QueryDoubleAttribute("base_height", &model->standing_base_height_m) !=
          tinyxml2::XML_SUCCESS ||
      !(model->standing_base_height_m > 0.0) || !std::isfinite(model->standing_base_height_m))
    Fail(source, "<hyq_posture name=\"standing\"> (line " + std::to_string(posture->GetLineNum()) +
                     "): expected a positive, finite base_height attribute");
  std::array<bool, kNumJoints> seen{};
  for (auto* j = posture->FirstChildElement("joint"); j != nullptr;
       j = j->NextSiblingElement("joint")) {
    const char* n = j->Attribute("name");
    double pos = 0.0;
    const std::string line = " (line " + std::to_string(j->GetLineNum()) + ")";
    if (n == nullptr || j->QueryDoubleAttribute("position", &pos) != tinyxml2::XML_SUCCESS)
      Fail(source, "<hyq_posture> <joint>" + line + ": expected name and position attributes");
    int idx = -1;
    for (int i = 0; i < kNumJoints; ++i)
      if (names[i] == n) idx = i;
    if (idx < 0) Fail(source, "<hyq_posture> <joint>" + line + ": unknown joint '" + n + "'");
    // the posture is where the robot is driven after enable: inside the joint's own limits
    const JointLimits& lim = model->limits[static_cast<std::size_t>(idx)];
    if (!std::isfinite(pos) || pos < lim.lower_rad || pos > lim.upper_rad)
      Fail(source, "<hyq_posture> <joint name=\"" + std::string(n) + "\">" + line +
                       ": expected a position within the joint's limits [" + Num(lim.lower_rad) +
                       ", " + Num(lim.upper_rad) + "] rad, found " + Num(pos));
    model->q_standing(idx) = pos;
    seen[idx] = true;
  }
  for (int i = 0; i < kNumJoints; ++i)
    if (!seen[i])
      Fail(source, "<hyq_posture name=\"standing\">: expected a position for joint '" + names[i] +
                       "', found none");
}

}  // namespace

Model LoadModelFromUrdf(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ModelError(path + ": cannot open URDF file (expected a readable file)");
  std::stringstream buf;
  buf << in.rdbuf();
  return LoadModelFromUrdfString(buf.str(), path);
}

Model LoadModelFromUrdfString(const std::string& xml, const std::string& source) {
  tinyxml2::XMLDocument doc;
  if (doc.Parse(xml.c_str(), xml.size()) != tinyxml2::XML_SUCCESS)
    Fail(source, "not well-formed XML: line " + std::to_string(doc.ErrorLineNum()) + ": " +
                     doc.ErrorStr());
  if (doc.FirstChildElement("robot") == nullptr)
    Fail(source, "expected a <robot> root element, found none");
  const urdf::ModelInterfaceSharedPtr urdf = urdf::parseURDF(xml);
  if (!urdf) Fail(source, "urdfdom rejected the file (its message is printed above)");

  Model model;
  model.source = source;

  // the floating base: root link with an inertial, or a massless root with a floating joint
  urdf::LinkConstSharedPtr trunk = urdf->getRoot();
  if (!trunk->inertial) {
    if (trunk->child_joints.size() != 1 || trunk->child_joints[0]->type != urdf::Joint::FLOATING)
      Fail(source, "root link '" + trunk->name +
                       "' has no inertial: expected exactly one floating joint from it to the "
                       "trunk, found " + std::to_string(trunk->child_joints.size()) +
                       " child joint(s)" +
                       (trunk->child_joints.empty() ? "" : " of another type"));
    trunk = urdf->getLink(trunk->child_joints[0]->child_link_name);
  }

  // the 12 actuated joints, by name, and nothing else that moves
  std::vector<std::string> actuated;
  for (const auto& [name, j] : urdf->joints_)
    if (j->type != urdf::Joint::FIXED && j->type != urdf::Joint::FLOATING) actuated.push_back(name);
  std::vector<std::string> missing;
  for (int leg = 0; leg < kNumLegs; ++leg)
    for (int k = 0; k < kJointsPerLeg; ++k) {
      const std::string n = std::string(kLegNames[leg]) + "_" + kLegJointNames[k] + "_joint";
      model.joint_names[JointIndex(leg, k)] = n;
      if (!urdf->getJoint(n)) missing.push_back(n);
    }
  if (actuated.size() != kNumJoints || !missing.empty()) {
    std::string found;
    for (const auto& n : actuated) found += (found.empty() ? "" : ", ") + n;
    std::string miss;
    for (const auto& n : missing) miss += (miss.empty() ? "" : ", ") + n;
    Fail(source, "expected 12 actuated joints {lf,rf,lh,rh}_{haa,hfe,kfe}_joint, found " +
                     std::to_string(actuated.size()) + " (" + found + ")" +
                     (miss.empty() ? "" : "; missing: " + miss));
  }

  // the trunk and its fixed children (IMU)
  auto add_body = [&](int index, const urdf::Link& link, int parent,
                      const urdf::Joint* joint) {
    Body& b = model.bodies[index];
    b.name = link.name;
    b.parent = parent;
    if (joint != nullptr) {
      b.R_PJ = ToMatrix(joint->parent_to_joint_origin_transform.rotation);
      b.p_PJ_P = ToVector(joint->parent_to_joint_origin_transform.position);
      const Eigen::Vector3d axis = ToVector(joint->axis);
      if (!(axis.norm() > 0.0)) Fail(source, "joint '" + joint->name + "': zero axis");
      b.axis_B = axis.normalized();
    }
    b.inertia = LinkInertia(link);
    std::vector<FixedChild> fixed;
    CollectFixed(link, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), &fixed);
    for (const FixedChild& f : fixed) Lump(&b.inertia, LinkInertia(*f.link), f.R, f.p);
    CheckInertia(source, link.name, b.inertia);
    return fixed;
  };

  for (const FixedChild& f : add_body(kTrunk, *trunk, -1, nullptr))
    if (f.link->name == "trunk_imu") model.imu = {f.link->name, kTrunk, f.R, f.p};
  if (model.imu.name.empty()) model.imu.name = trunk->name;

  for (int leg = 0; leg < kNumLegs; ++leg) {
    urdf::LinkConstSharedPtr parent = trunk;
    int parent_body = kTrunk;
    for (int k = 0; k < kJointsPerLeg; ++k) {
      const int j = JointIndex(leg, k);
      const auto joint = urdf->getJoint(model.joint_names[j]);
      if (joint->type != urdf::Joint::REVOLUTE && joint->type != urdf::Joint::CONTINUOUS)
        Fail(source, "joint '" + joint->name + "': expected type revolute");
      if (joint->parent_link_name != parent->name)
        Fail(source, "joint '" + joint->name + "': expected parent link '" + parent->name +
                         "', found '" + joint->parent_link_name + "'");
      const auto child = urdf->getLink(joint->child_link_name);
      const auto fixed = add_body(BodyOfJoint(j), *child, parent_body, joint.get());

      JointLimits& lim = model.limits[j];
      if (!joint->limits)
        Fail(source, "joint '" + joint->name + "': expected a <limit> element, found none");
      lim = {joint->limits->lower, joint->limits->upper, joint->limits->velocity,
             joint->limits->effort};
      if (!(lim.lower_rad < lim.upper_rad) || !(lim.velocity_rad_s > 0.0) ||
          !(lim.effort_Nm > 0.0))
        Fail(source, "joint '" + joint->name + "' <limit>: expected lower < upper and positive "
                     "velocity and effort, found lower " + Num(lim.lower_rad) + ", upper " +
                     Num(lim.upper_rad) + ", velocity " + Num(lim.velocity_rad_s) +
                     ", effort " + Num(lim.effort_Nm));

      if (k == kJointsPerLeg - 1) {
        const std::string foot = std::string(kLegNames[leg]) + "_foot";
        const FixedChild* found = nullptr;
        for (const FixedChild& f : fixed)
          if (f.link->name == foot) found = &f;
        if (found == nullptr)
          Fail(source, "expected a foot link '" + foot + "' fixed to '" + child->name +
                           "', found none");
        double radius = 0.0;
        for (const auto& c : found->link->collision_array)
          if (c->geometry && c->geometry->type == urdf::Geometry::SPHERE)
            radius = static_cast<const urdf::Sphere&>(*c->geometry).radius;
        if (!(radius > 0.0))
          Fail(source, "link '" + foot + "': expected a <collision> sphere giving the foot "
                       "radius, found none");
        FootFrame& ff = model.feet[leg];
        ff.name = foot;
        ff.body = BodyOfJoint(j);
        ff.R_BF = found->R;
        ff.p_BF_B = found->p;
        ff.radius_m = radius;
      }
      parent = child;
      parent_body = BodyOfJoint(j);
    }
  }

  ReadPosture(doc, source, model.joint_names, &model);
  return model;
}

}  // namespace hyq::dynamics
