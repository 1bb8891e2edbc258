#!/usr/bin/env bash
# `step NAME COMMAND...`: runs a step of a CI script and says how long it
# took, so a slow CI run shows where its time went. Sourced.
step() {
  local name=$1 start=$SECONDS
  shift
  "$@"
  echo "step $name: $((SECONDS - start)) s"
}
