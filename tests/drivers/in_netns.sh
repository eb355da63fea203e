#!/bin/sh
# Runs a test command in its own network namespace that has only loopback, with multicast routed
# to lo, so multicast tests send nothing off this machine and parallel tests do not hear each
# other. Sets HYQ_NETNS=1 inside; tests that need multicast skip (and say why) without it.
if unshare -n true 2>/dev/null; then
  exec unshare -n sh -c 'ip link set lo up && ip route add 224.0.0.0/4 dev lo && export HYQ_NETNS=1 && exec "$@"' in_netns "$@"
fi
echo "in_netns.sh: cannot create a network namespace (unshare -n needs root or user namespaces);" \
     "multicast tests will skip" >&2
exec "$@"
