#!/bin/sh
# SPDX-License-Identifier: MIT
# Shared helpers of the scripts/ci-*.sh checks (sourced, not run): package installs and the
# CLI smoke runs that the sanitizer and valgrind checks execute under their tools.

# ci_need CMD PACKAGE...: install the Debian packages when CMD is missing (root, non-interactive).
ci_need() {
    cmd=$1
    shift
    command -v "$cmd" >/dev/null 2>&1 && return 0
    sudo=""
    [ "$(id -u)" -eq 0 ] || sudo="sudo"
    echo "ci: installing $*" >&2
    DEBIAN_FRONTEND=noninteractive $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "$@" >/dev/null
}

# ci_cli_smoke ROOT DTH [RUNNER...]: run the dth CLI over the shipped scenes and bad inputs, each
# under RUNNER (e.g. valgrind ...). A tool error must exit with 86; any exit code outside the
# expected set fails. Prints the number of runs; returns non-zero on the first failure.
ci_cli_smoke() {
    root=$1
    dth=$2
    shift 2
    tmp=$(mktemp -d)
    runs=0
    fails=0
    # expect CODES ARGS...: CODES is a '|'-separated list of allowed exit codes
    expect() {
        codes=$1
        shift
        runs=$((runs + 1))
        set +e
        "$@" >"$tmp/out" 2>"$tmp/err"
        rc=$?
        set -e
        case "|$codes|" in
        *"|$rc|"*) ;;
        *)
            fails=$((fails + 1))
            echo "ci-smoke: exit $rc (expected $codes): $*" >&2
            tail -n 40 "$tmp/err" >&2
            ;;
        esac
    }
    expect 0 "$@" "$dth" --help
    expect 0 "$@" "$dth" --version
    expect 0 "$@" "$dth" models
    for s in "$root"/scenes/*.ini; do
        # 3: the trajectory stopped early (e.g. the raw rotating pendulum): a clean, expected end
        expect '0|3' "$@" "$dth" run "$s" -o "$tmp/run.csv"
        expect '0|3' "$@" "$dth" run "$s" -s output.diagnostics=yes -s output.every=1 -s output.dt=0.05
    done
    p="$root/scenes/pendulum.ini"
    expect 0 "$@" "$dth" run "$p" -s integrator.start=vertex -s integrator.steps=50
    expect 2 "$@" "$dth" run "$root/scenes/no-such-scene.ini"
    expect 2 "$@" "$dth" run "$p" -s model.nope=1
    expect 2 "$@" "$dth" run "$p" -s integrator.h=0
    expect 2 "$@" "$dth" run "$p" -s initial.q=nan
    expect 2 "$@" "$dth" run "$p" -s model.omega2=-1
    expect 2 "$@" "$dth" run "$p" -s bad
    expect 2 "$@" "$dth" run "$p" -o /dev/null/x.csv
    # the run driver's other paths: events (section, time, terminal distance), output times, HDF5
    expect 0 "$@" "$dth" run "$p" -s events.section=p1 -s events.section_direction=both -s events.time=1.5 \
        -o "$tmp/ev.csv"
    expect 0 "$@" "$dth" run "$p" -s output.points=vertices -s events.distance=0.5 -s events.distance_terminal=yes \
        -o "$tmp/evt.csv"
    expect 0 "$@" "$dth" run "$root/scenes/kepler-e06.ini" -s output.dt=0.1 -s events.section=q2 -o "$tmp/k.h5"
    expect 0 "$@" "$dth" run "$p" --progress=0.01 -s integrator.steps=2000 -o "$tmp/pr.csv"
    # checkpoints: written, resumed into the same file, refused overrides, a folder as checkpoint
    expect 0 "$@" "$dth" run "$p" -s integrator.steps=300 -o "$tmp/c.csv" --checkpoint "$tmp/c.ckpt" --checkpoint-every 50
    expect 0 "$@" "$dth" run --resume "$tmp/c.ckpt" -s integrator.steps=600 --checkpoint "$tmp/c.ckpt"
    expect 2 "$@" "$dth" run --resume "$tmp/c.ckpt" -s model.omega2=2 -o "$tmp/c2.csv"
    expect 2 "$@" "$dth" run --resume "$tmp"
    # dth sweep (OpenMP threads; MPI is covered by meson test cli-sweep-mpi): a grid with MEGNO and
    # trajectories, a list with a baseline method, a refused key
    expect 0 "$@" "$dth" sweep "$p" --vary initial.q=0.5:1:3 --vary initial.p=0:0.5:2 -s integrator.t_end=2 \
        --trajectories "$tmp/sw/r" -o "$tmp/sw.csv"
    printf 'initial.q,integrator.h\n0.5,0.05\n"1",0.1\n' >"$tmp/list.csv"
    expect 0 "$@" "$dth" sweep "$p" --list "$tmp/list.csv" -s integrator.method=rk4 -s integrator.t_end=2 -o "$tmp/sl.csv"
    expect 2 "$@" "$dth" sweep "$p" --vary model.nope=0:1:2
    expect 2 "$@" "$dth" run
    expect 2 "$@" "$dth" frobnicate
    printf '[model]\nname = pendulum\n[initial]\nq = 1,\n' >"$tmp/bad.ini"
    expect 2 "$@" "$dth" run "$tmp/bad.ini"
    printf '[model\nname = \377\376\n' >"$tmp/garbage.ini"
    expect 2 "$@" "$dth" run "$tmp/garbage.ini"
    rm -rf "$tmp"
    echo "ci-smoke: $runs CLI runs, $fails failed"
    [ "$fails" -eq 0 ]
}
