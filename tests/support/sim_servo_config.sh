# Sourced by the test scripts that run hyq-servod on an edited copy of the shipped simulation
# configuration. The shipped file names its URDF and HAL configuration relative to its own folder,
# so a copy written elsewhere names them by absolute path.
#
# sim_servo_config SOURCE_DIR FILE HAL [SED_ARG...]: writes SOURCE_DIR/config/hyq_servo_sim.yaml
# to FILE with the URDF's path and HAL's (the HAL configuration to use) absolute, edited further by
# the extra sed arguments (-e EXPRESSION ...)
sim_servo_config() {
  local src=$1 file=$2 hal=$3
  shift 3
  sed -e "s|^  urdf: .*|  urdf: $src/config/robots/hyq.urdf|" -e "s|^  hal: .*|  hal: $hal|" "$@" \
      "$src/config/hyq_servo_sim.yaml" > "$file"
}
