#!/usr/bin/env bash
# CI smoke: every fuzz target for a few seconds (about a minute for all), failing on any crash,
# oom or timeout. See run.sh for the full campaign.
set -euo pipefail
cd "$(dirname "$0")"
n=$(cargo fuzz list --fuzz-dir . | grep -cvx stress)
per=$(( 60 / n > 3 ? 60 / n : 3 ))
exec ./run.sh -t "$per"
