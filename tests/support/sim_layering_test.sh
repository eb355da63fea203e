#!/bin/sh
# The plant sits below the controller: no file under sim/ includes a header of servo/, tools/,
# drivers/ or config/, and hyq::sim links none of their libraries.
# usage: sim_layering_test.sh SOURCE_DIR "LINK_LIBRARIES of hyq_sim (;-separated)"
src=$1
libs=$2
status=0
bad=$(grep -rnE '^[[:space:]]*#[[:space:]]*include[[:space:]]*"(servo|tools|drivers|config)/' "$src/sim" || true)
if [ -n "$bad" ]; then
  echo "sim/ includes a header from above it:"
  echo "$bad"
  status=1
fi
for lib in $(echo "$libs" | tr ';' ' '); do
  case $lib in
    *servo*|*drivers*|*config*|*experiment*)
      echo "hyq::sim links $lib"
      status=1;;
  esac
done
[ $status -eq 0 ] && echo "sim/ depends on hal/, dynamics/ and MuJoCo only"
exit $status
