#!/usr/bin/env bash
# Mutation testing of the pipeline's Python modules with mutmut 3 (docs/testing.md).
#
#   pip install "mutmut>=3.8,<4" && maturin develop --release
#   scripts/mutation.sh                 # every mutant not yet decided (resumes)
#   scripts/mutation.sh 'podid_rs.physical.*'   # only these mutants
#   scripts/mutation.sh --results       # the survivors of the last run
#   scripts/mutation.sh --summary       # killed, survived, not run per module
#   scripts/mutation.sh --not-run identification/order.py modes.py
#                                       # only these modules' mutants not yet run
#   scripts/mutation.sh --survivors     # run the survivors again (after new tests)
#   scripts/mutation.sh --sample 40 20261126 modes.py io/uff.py
#                                       # draw 40 not-run mutants of each module at random
#                                       # (seed 20261126) into docs/mutation-sample.txt and
#                                       # run them; --sample alone resumes that sample
#   scripts/mutation.sh --sample-share 130 20261127 modes.py io/uff.py
#                                       # 130 in all instead, split over the modules in
#                                       # proportion to their mutants not run
#   scripts/mutation.sh --restat        # forget which tests reach which function: the
#                                       # next run maps them again (after functions were
#                                       # added or moved; the verdicts are kept)
#   MUTATION_JOBS=2 scripts/mutation.sh # two mutants at a time (default one: the
#                                       # machine is shared)
#
# mutmut imports the mutated package from mutants/src/, so it runs in a staging
# directory, build/mutation/, where src/ is this repository's python/ (the compiled
# _core module is copied along with the sources) and tests/ and pyproject.toml are
# the repository's. The modules to mutate are [tool.mutmut] in pyproject.toml.
# Each mutant runs only the tests that called the mutated function when the suite
# ran once under mutmut's trampolines, fastest first, stopping at the first failure
# (scripts/mutmut_fastest_first.py: mutmut's fork server would take them in a random order).
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
stage="$repo/build/mutation"
mkdir -p "$stage"
ln -sfn "$repo/python" "$stage/src"
ln -sfn "$repo/tests" "$stage/tests"
ln -sfn "$repo/pyproject.toml" "$stage/pyproject.toml"
cd "$stage"
# mutmut copies each file of src/ into mutants/src/ once and refreshes only the Python
# ones: bring the compiled core and its stub along every time (maturin develop rebuilds
# the core; a stale stub fails test_core_stub.py in the mapping run, which then stops)
if [[ -d mutants/src/podid_rs ]]; then
    rm -f mutants/src/podid_rs/_core*.so
    cp -p "$repo"/python/podid_rs/_core*.so "$repo"/python/podid_rs/_core.pyi \
        mutants/src/podid_rs/
fi
# one BLAS thread per mutant worker; the machine is shared, so run at the lowest priority
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 RAYON_NUM_THREADS=1
if [[ "${1:-}" == "--restat" ]]; then
    # mutmut maps tests to functions in one full run and afterwards only for new tests: a
    # function added later (or newly reached by old tests) keeps no or too few tests
    rm -f mutants/mutmut-stats.json
    exit 0
fi
if [[ "${1:-}" == "--results" ]]; then
    exec python -m mutmut results
fi
if [[ "${1:-}" == "--summary" ]]; then
    exec python "$repo/scripts/mutation_summary.py"
fi
if [[ "${1:-}" == "--not-run" ]]; then
    shift
    mapfile -t names < <(python "$repo/scripts/mutation_summary.py" --not-run "$@")
    if (( ${#names[@]} == 0 )); then
        echo "every mutant of $* has run"
        exit 0
    fi
    set -- "${names[@]}"
elif [[ "${1:-}" == "--sample" || "${1:-}" == "--sample-share" ]]; then
    how="$1"
    shift
    if (( $# > 0 )); then
        python "$repo/scripts/mutation_summary.py" "$how" "$@" > /dev/null
    fi
    mapfile -t sampled < <(grep -v '^#' "$repo/docs/mutation-sample.txt")
    mapfile -t pending < <(python "$repo/scripts/mutation_summary.py" --not-run-of "${sampled[@]}")
    if (( ${#pending[@]} == 0 )); then
        echo "every mutant of the sample has run"
        exit 0
    fi
    set -- "${pending[@]}"
elif [[ "${1:-}" == "--survivors" ]]; then
    mapfile -t names < <(python -m mutmut results 2>/dev/null |
        awk -F': ' '$2 ~ /^(survived|no tests|suspicious)$/ {gsub(/ /, "", $1); print $1}')
    if (( ${#names[@]} == 0 )); then
        echo "no survivors"
        exit 0
    fi
    set -- "${names[@]}"
fi
exec nice -n 19 python "$repo/scripts/mutmut_fastest_first.py" run --max-children "${MUTATION_JOBS:-1}" "$@"
