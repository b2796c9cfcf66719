#!/usr/bin/env bash
# The Python package (issue #52) as a user gets it: a wheel built from this checkout by maturin,
# installed into a fresh venv, then its pytest suite. The suite compares against the `starnet`
# binary, so that is built too. PROFILE=release builds the wheel a user would ship; CI uses the
# dev profile, whose dependencies (Burn, the data, model and metrics crates) are optimised as in
# release and already built by the Rust tests.
set -euo pipefail
cd "$(dirname "$0")/.."
profile="${PROFILE:-dev}"
venv=target/pyvenv
rm -rf "$venv" target/wheels
python3 -m venv "$venv"
"$venv/bin/pip" install --quiet --upgrade pip
"$venv/bin/pip" install --quiet "maturin>=1.9,<2" "pytest>=7"
cargo build --bin starnet
"$venv/bin/maturin" build --profile "$profile" -m starnet-py/Cargo.toml --out target/wheels -i "$venv/bin/python"
"$venv/bin/pip" install --quiet target/wheels/starnet-*.whl
# Run from the tests' folder so `import starnet` is the installed wheel, not a source tree.
cd starnet-py/tests
../../"$venv/bin/python" -m pytest -q
