#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# ehpt as a dependency (README "Install"), on the real build:
#  1. cmake --install into a temporary prefix; the installed ehpt runs psecu2_nedc from an
#     unrelated folder with the source tree hidden (a private mount namespace binds an empty
#     folder over it), reads only the installed files, and gives the build tree's timeseries;
#     --version, list, plot, $EHPT_SCENARIOS;
#  2. examples/embed builds against the installed CMake package and, with its own ECU
#     callback, reproduces `ehpt run ev_nedc`; with a torque limit it does not;
#  3. the installed Python module (if built) finds the installed scenarios;
#  4. cpack builds the Debian packages; dpkg-deb --info shows their dependencies, dpkg -x
#     unpacks ehpt_<version>-<revision>_amd64.deb and its ehpt runs a scenario; apt-get resolves the
#     package's dependencies (a simulation: nothing is installed on this machine);
#  5. each package (docs/packaging.md): lintian reports no error (all its output printed),
#     it carries packaging/copyright and a changelog.Debian.gz, an extended description;
#     ehpt has the man page (man -l renders it without a warning), a stripped ehpt, the
#     Suggests, the example ECUs (the CAN one finds the installed DBC); ehpt-dev has the
#     static libraries and the CMake package under the multiarch folder only; python3-ehpt a
#     stripped module.
# usage: install_test.sh SOURCE_DIR BUILD_DIR VERSION DEB_VERSION (0.1.0 and 0.1.0-1)
set -euo pipefail
src="$1" build="$2" version="$3" debversion="$4"
tmp="$(mktemp -d /tmp/ehpt-install-test.XXXXXX)"
trap 'rm -rf "$tmp"' EXIT  # made above by this script, nothing else
fail() { echo "FAIL: $*" >&2; exit 1; }
prefix="$tmp/prefix"
mkdir -p "$tmp/elsewhere" "$tmp/empty"
multiarch="$(dpkg-architecture -qDEB_HOST_MULTIARCH)"  # x86_64-linux-gnu

echo "== 1. cmake --install --prefix $prefix"
cmake --install "$build" --prefix "$prefix" >"$tmp/install.log"
for f in bin/ehpt libexec/ehpt/plot.py share/ehpt/scenarios/psecu2_nedc.toml share/ehpt/vehicles/psecu2.toml \
         share/ehpt/data/cycles/cycle_nedc.csv share/ehpt/campaigns/psecu2_calibration.toml share/ehpt/can/ehpt.dbc \
         share/ehpt/lcm/psd_sensors_t.lcm include/ehpt/hil/run/simulation.hpp include/ehpt/plant/psd_plant.hpp \
         include/ehpt/ehpt_lcm/psd_sensors_t.hpp "lib/$multiarch/libehpt_hil.a" "lib/$multiarch/cmake/ehpt/ehptConfig.cmake" \
         "lib/$multiarch/cmake/ehpt/ehptTargets.cmake" share/man/man1/ehpt.1.gz share/doc/ehpt/copyright \
         share/doc/ehpt/changelog.Debian.gz share/doc/ehpt/examples/pycan_ecu.py share/doc/ehpt/examples/embed/main.cpp \
         lib/ehpt/fmu/libehpt_fmu3.so lib/ehpt/fmu/libehpt_fmu2.so; do
  [ -e "$prefix/$f" ] || fail "the install has no $f"
done
! ls "$prefix"/lib/*.a >/dev/null 2>&1 || fail "static libraries outside lib/$multiarch: $(ls "$prefix"/lib/*.a)"
ehpt="$prefix/bin/ehpt"
cd "$tmp/elsewhere"
"$ehpt" --version | tee "$tmp/version.txt"
head -1 "$tmp/version.txt" | grep -q "^ehpt $version" || fail "--version does not say ehpt $version"
env -u EHPT_SCENARIOS "$ehpt" list >"$tmp/list.txt"
grep -q "^psecu2_nedc" "$tmp/list.txt" || fail "the installed ehpt does not list psecu2_nedc"

# the source tree hidden: only the installed files can be read
hidden=(env -u EHPT_SCENARIOS -u EHPT_TOOLS_DIR)
if unshare -m --propagation private true 2>/dev/null; then
  hidden=(unshare -m --propagation private -- sh -c 'mount --bind "$1" "$2" && shift 2 && exec env -u EHPT_SCENARIOS -u EHPT_TOOLS_DIR "$@"'
          sh "$tmp/empty" "$src")
  "${hidden[@]}" test ! -e "$src/CMakeLists.txt" || fail "the source tree is not hidden"
else
  echo "note: no private mount namespace here: the source tree is not hidden (the input paths are still checked)"
fi
"${hidden[@]}" "$ehpt" run psecu2_nedc --out run_installed --quiet
/usr/bin/python3 - "$tmp/elsewhere/run_installed/summary.json" "$prefix/share/ehpt/" <<'EOF'
import json, sys
s = json.load(open(sys.argv[1]))
p = s["provenance"]
paths = [i["path"] for i in p["inputs"]]
assert len(paths) >= 5, paths
bad = [q for q in paths if not q.startswith(sys.argv[2])]
assert not bad, f"inputs read outside the installed share/ehpt: {bad}"
assert s["status"] == "ok", s["status"]
print(f"installed run: {len(paths)} inputs, all under {sys.argv[2]}; run_id {p['run_id'][:12]}")
EOF
# the installed ehpt packs an FMU with its own library (source tree hidden)
"${hidden[@]}" "$ehpt" fmu psecu2_nedc --set solver.duration_s=1 --out fmu_installed.fmu >/dev/null
/usr/bin/python3 - "$tmp/elsewhere/fmu_installed.fmu" <<'EOF'
import sys, zipfile
names = zipfile.ZipFile(sys.argv[1]).namelist()
for want in ("modelDescription.xml", "binaries/x86_64-linux/ehpt_psecu2_nedc.so", "resources/ehpt-fmu.txt",
             "resources/vehicles/psecu2.toml"):
    assert want in names, (want, names)
print(f"installed ehpt fmu: {len(names)} files")
EOF
# and with the source tree in view: the installed ehpt still reads only its own files
env -u EHPT_SCENARIOS "$ehpt" run ev_nedc --set solver.duration_s=10 --out run_visible --quiet
/usr/bin/python3 - "$tmp/elsewhere/run_visible/summary.json" "$prefix/share/ehpt/" <<'EOF'
import json, sys
paths = [i["path"] for i in json.load(open(sys.argv[1]))["provenance"]["inputs"]]
assert paths and all(q.startswith(sys.argv[2]) for q in paths), f"an installed ehpt read {paths}"
EOF
"$build/ehpt" run "$src/scenarios/psecu2_nedc.toml" --out "$tmp/run_build" --quiet
cmp "$tmp/elsewhere/run_installed/timeseries.csv" "$tmp/run_build/timeseries.csv" ||
  fail "the installed ehpt's timeseries differs from the build tree's"
# the same files, another place: the same run id (paths are not part of it)
/usr/bin/python3 - "$tmp/elsewhere/run_installed/summary.json" "$tmp/run_build/summary.json" <<'EOF'
import json, sys
a, b = (json.load(open(f))["provenance"] for f in sys.argv[1:])
assert a["run_id"] == b["run_id"], (a["run_id"], b["run_id"])
assert [i["sha256"] for i in a["inputs"]] == [i["sha256"] for i in b["inputs"]]
EOF
# an own scenario in an empty folder names the shipped vehicle: vehicle = "psecu2" resolves to the
# installed vehicles/psecu2.toml (no path to the package in the scenario but the cycle's)
mkdir -p "$tmp/own"
printf 'description = "mine"\nvehicle = "psecu2"\ncycle = "%s"\n[solver]\nduration_s = 60.0\n' \
  "$prefix/share/ehpt/data/cycles/cycle_nedc.csv" >"$tmp/own/mine.toml"
(cd "$tmp/own" && "${hidden[@]}" "$ehpt" run mine.toml --set vehicle.vehicle.mass_kg=1800 --out run_named --quiet) ||
  fail "a scenario with vehicle = \"psecu2\" does not run with the installed package"
/usr/bin/python3 - "$tmp/own/run_named/summary.json" "$prefix/share/ehpt/vehicles/psecu2.toml" <<'EOF'
import json, sys
s = json.load(open(sys.argv[1]))
paths = [i["path"] for i in s["provenance"]["inputs"]]
assert sys.argv[2] in paths, f"the installed psecu2.toml is not among the inputs: {paths}"
assert s["status"] == "ok" and s["distance_m"] > 50.0, (s["status"], s["distance_m"])
print(f"vehicle = \"psecu2\" from an empty folder: {s['distance_m']:.1f} m, inputs {paths[:2]}")
EOF
"${hidden[@]}" "$ehpt" plot run_installed >/dev/null
ls run_installed/*.png >/dev/null || fail "the installed plot tool drew nothing"
# $EHPT_SCENARIOS still wins over the installed folder
mkdir -p "$tmp/myscenarios"
sed 's/^description = .*/description = "mine"/' "$prefix/share/ehpt/scenarios/ev_nedc.toml" |
  sed "s#\"\.\./#\"$prefix/share/ehpt/#g" >"$tmp/myscenarios/ev_mine.toml"
EHPT_SCENARIOS="$tmp/myscenarios" "$ehpt" list | grep -q "^ev_mine *mine" || fail "\$EHPT_SCENARIOS is not honoured"

# an ehpt without data (the binary copied alone): a clear error, exit 1 / 2, nothing run
mkdir -p "$tmp/lonely/bin" && cp "$ehpt" "$tmp/lonely/bin/ehpt"
rc=0; EHPT_SCENARIOS= "$tmp/lonely/bin/ehpt" list 2>"$tmp/lonely.err" || rc=$?
[ "$rc" -eq 1 ] && grep -qF "no scenarios folder found (looked in ./scenarios, $tmp/lonely/share/ehpt/scenarios" "$tmp/lonely.err" ||
  { cat "$tmp/lonely.err"; fail "ehpt list without data: rc $rc"; }
rc=0; "${hidden[@]}" "$tmp/lonely/bin/ehpt" run ev_nedc --out lonely_run 2>"$tmp/lonely.err" || rc=$?
[ "$rc" -eq 2 ] && grep -q "no scenarios folder found" "$tmp/lonely.err" && [ ! -e lonely_run ] ||
  { cat "$tmp/lonely.err"; fail "ehpt run without data: rc $rc"; }

# only the exact layout <prefix>/bin/ehpt counts: folders further up (anyone may write /tmp)
# are never searched, for data or for a plot tool to run
mkdir -p "$tmp/up/a/bin" "$tmp/up/share/ehpt/scenarios" "$tmp/up/libexec/ehpt"
cp "$ehpt" "$tmp/up/a/bin/ehpt"
cp "$prefix/share/ehpt/scenarios/ev_nedc.toml" "$tmp/up/share/ehpt/scenarios/"
printf 'open("%s/planted_ran", "w").close()\n' "$tmp" >"$tmp/up/libexec/ehpt/plot.py"
rc=0; "$tmp/up/a/bin/ehpt" list 2>"$tmp/up.err" >/dev/null || rc=$?
[ "$rc" -eq 1 ] || fail "a binary two folders below a share/ehpt took it (ehpt list: rc $rc)"
rc=0; EHPT_TOOLS_DIR= "$tmp/up/a/bin/ehpt" plot run_installed 2>"$tmp/up.err" || rc=$?
[ "$rc" -ne 0 ] && [ ! -e "$tmp/planted_ran" ] && grep -q "no plot tool found" "$tmp/up.err" ||
  { cat "$tmp/up.err"; fail "a plot.py two folders above the binary ran (rc $rc)"; }

echo "== 2. examples/embed against the installed CMake package"
cmake -S "$src/examples/embed" -B "$tmp/embed" -DCMAKE_PREFIX_PATH="$prefix" >"$tmp/embed-cmake.log" ||
  { cat "$tmp/embed-cmake.log"; fail "find_package(ehpt) failed"; }
cmake --build "$tmp/embed" -j"$(nproc)" >"$tmp/embed-build.log" || { cat "$tmp/embed-build.log"; fail "the embed example does not build"; }
"${hidden[@]}" "$tmp/embed/embed_ecu" >"$tmp/embed.txt"
"${hidden[@]}" "$tmp/embed/embed_ecu" --torque-limit-Nm 100 >"$tmp/embed_limited.txt"
"$ehpt" run ev_nedc --out "$tmp/ev_nedc" --quiet
# a scenario by name in the embedding program: the installed library knows the data folder it
# was configured for (<CMAKE_INSTALL_PREFIX>/share/ehpt, compiled into hil/config/scenario.cpp).
# This install went to $prefix instead, so the configured folder is given the installed data in
# a private mount namespace (a tmpfs over its nearest existing parent, seen by this process only)
configured="$(sed -n 's/^CMAKE_INSTALL_PREFIX:[A-Z]*=//p' "$build/CMakeCache.txt")/share/ehpt"
parent="$configured"; while [ ! -d "$parent" ]; do parent="$(dirname "$parent")"; done
if [ ! -e "$configured" ]; then
  # without the data there the name does not resolve: it is that folder the library looks in
  rc=0; (cd "$tmp/elsewhere" && "${hidden[@]}" "$tmp/embed/embed_ecu" --scenario ev_nedc) >/dev/null 2>"$tmp/embed_name.err" || rc=$?
  [ "$rc" -eq 2 ] && grep -q "no such scenario file or name" "$tmp/embed_name.err" ||
    { cat "$tmp/embed_name.err"; fail "embed_ecu --scenario ev_nedc: rc $rc without the configured data folder"; }
fi
if [ "$parent" != "/" ] && unshare -m --propagation private true 2>/dev/null; then
  (cd "$tmp/elsewhere" && unshare -m --propagation private -- sh -c '
     mount --bind "$1" "$2" || exit 90
     if [ "$3" != "$4" ]; then mount -t tmpfs tmpfs "$4" && mkdir -p "$3" || exit 91; fi
     mount --bind "$5" "$3" || exit 92
     exec env -u EHPT_SCENARIOS "$6" --scenario ev_nedc' \
     sh "$tmp/empty" "$src" "$configured" "$parent" "$prefix/share/ehpt" "$tmp/embed/embed_ecu") >"$tmp/embed_name.txt" ||
    fail "embed_ecu --scenario ev_nedc (by name, the installed library's data folder $configured) failed"
  cmp "$tmp/embed.txt" "$tmp/embed_name.txt" || fail "embed_ecu by name differs from the run by path"
  echo "embed: --scenario ev_nedc resolved in the configured data folder $configured"
else
  echo "note: no private mount namespace (or no parent of $configured): the name lookup of the embedding program is not checked"
fi
/usr/bin/python3 - "$tmp/embed.txt" "$tmp/embed_limited.txt" "$tmp/ev_nedc/summary.json" <<'EOF'
import json, sys
def figures(path):
    return {k: float(v) for k, v in (line.split() for line in open(path))}
own, limited = figures(sys.argv[1]), figures(sys.argv[2])
s = json.load(open(sys.argv[3]))
# its own ECU without a limit is the built-in follower: the same run, bit for bit
assert own["distance_m"] == s["distance_m"], (own["distance_m"], s["distance_m"])
assert own["soc_end"] == s["soc_end"], (own["soc_end"], s["soc_end"])
assert own["steps"] == s["steps"] and own["fault"] == 0
# with 100 N m it falls behind in the cycle's hardest accelerations (30 m over NEDC, measured):
# it is the harness's ECU that drives
assert limited["distance_m"] < own["distance_m"] - 10.0, (limited, own)
print(f"embed: {own['distance_m']:.3f} m, SOC {own['soc_end']:.6f} (= ehpt run); limited to 100 N m: {limited['distance_m']:.3f} m")
EOF

pymod_dir="$prefix/lib/python3/dist-packages"
if ls "$pymod_dir"/ehpt*.so >/dev/null 2>&1; then
  echo "== 3. the installed Python module"
  "${hidden[@]}" env PYTHONPATH="$pymod_dir" /usr/bin/python3 -c '
import ehpt, sys
r = ehpt.run("ev_nedc", set={"solver.duration_s": 60})
paths = [i["path"] for i in r.summary["provenance"]["inputs"]]
assert all(p.startswith(sys.argv[1]) for p in paths), paths
assert r.exit_code == 0
print("python: ehpt.run(\"ev_nedc\") from the install,", len(r.timeseries["time_s"]), "rows")
' "$prefix/share/ehpt/"
  # the module's own prefix, not the interpreter's: a python3 with another share/ehpt next to it
  mkdir -p "$tmp/other/bin" "$tmp/other/share/ehpt/scenarios"
  cp "$(readlink -f /usr/bin/python3)" "$tmp/other/bin/python3"
  cp "$prefix/share/ehpt/scenarios/ev_nedc.toml" "$tmp/other/share/ehpt/scenarios/"
  env -u EHPT_SCENARIOS PYTHONPATH="$pymod_dir" "$tmp/other/bin/python3" -c '
import ehpt, sys
p = ehpt.run("ev_nedc", set={"solver.duration_s": 5}).summary["provenance"]["inputs"][0]["path"]
assert p.startswith(sys.argv[1]), f"the module took {p}, not its own prefix {sys.argv[1]}"
' "$prefix/share/ehpt/"
else
  echo "== 3. no Python module in the install (EHPT_BUILD_PYTHON=OFF): skipped"
fi

echo "== 4. cpack -G DEB"
(cd "$build" && cpack -G DEB -B "$tmp/pkg" >"$tmp/cpack.log") || { cat "$tmp/cpack.log"; fail "cpack failed"; }
deb="$tmp/pkg/ehpt_${debversion}_amd64.deb"
[ -f "$deb" ] || { ls "$tmp/pkg"; fail "no ehpt_${debversion}_amd64.deb"; }
[ -f "$tmp/pkg/ehpt-dev_${debversion}_amd64.deb" ] || fail "no ehpt-dev_${debversion}_amd64.deb"
dpkg-deb --info "$deb" | tee "$tmp/info.txt"
depends="$(dpkg-deb --field "$deb" Depends)"
for d in libc6 libstdc++6 liblcm1 python3-matplotlib; do
  grep -q "$d" <<<"$depends" || fail "Depends lacks $d: $depends"
done
dpkg-deb --info "$tmp/pkg/ehpt-dev_${debversion}_amd64.deb" | grep -E "Package|Depends"
dpkg -x "$deb" "$tmp/root"
[ ! -e "$tmp/root/usr/include" ] || fail "the runtime package holds headers"
cd "$tmp/elsewhere"
"${hidden[@]}" "$tmp/root/usr/bin/ehpt" run ev_nedc --set solver.duration_s=60 --out run_deb --quiet
/usr/bin/python3 - "$tmp/elsewhere/run_deb/summary.json" "$tmp/root/usr/share/ehpt/" <<'EOF'
import json, sys
p = json.load(open(sys.argv[1]))["provenance"]
assert all(i["path"].startswith(sys.argv[2]) for i in p["inputs"]), p["inputs"]
assert p["overrides"] == ["solver.duration_s=60"], p["overrides"]
EOF
if ls "$pymod_dir"/ehpt*.so >/dev/null 2>&1; then
  pydeb="$tmp/pkg/python3-ehpt_${debversion}_amd64.deb"
  [ -f "$pydeb" ] || fail "no python3-ehpt_${debversion}_amd64.deb"
  pydepends="$(dpkg-deb --field "$pydeb" Depends)"
  echo "python3-ehpt Depends: $pydepends"
  grep -q "ehpt (= $debversion)" <<<"$pydepends" && grep -q "python3-numpy" <<<"$pydepends" ||
    fail "python3-ehpt's Depends lacks ehpt or numpy: $pydepends"
  dpkg -x "$pydeb" "$tmp/root"
  "${hidden[@]}" env PYTHONPATH="$tmp/root/usr/lib/python3/dist-packages" /usr/bin/python3 -c '
import ehpt, sys
r = ehpt.run("ev_nedc", set={"solver.duration_s": 10})
assert all(i["path"].startswith(sys.argv[1]) for i in r.summary["provenance"]["inputs"]), r.summary["provenance"]
print("python3-ehpt: the unpacked module runs ev_nedc from", sys.argv[1])
' "$tmp/root/usr/share/ehpt/"
fi
if [ "$(id -u)" -eq 0 ]; then
  apt-get install -s "$deb" >"$tmp/apt.log" 2>&1 || { cat "$tmp/apt.log"; fail "apt cannot resolve the package's dependencies"; }
  grep -E "^Inst ehpt " "$tmp/apt.log" || fail "apt would not install ehpt"
fi
echo "== 5. lintian and the contents of each package"
for tool in lintian man file; do
  command -v "$tool" >/dev/null || fail "no $tool here (tools/setup.sh installs it)"
done
packages=(ehpt ehpt-dev)
ls "$pymod_dir"/ehpt*.so >/dev/null 2>&1 && packages+=(python3-ehpt)
for p in "${packages[@]}"; do
  d="$tmp/pkg/${p}_${debversion}_amd64.deb"
  echo "-- lintian $p"
  # every tag printed (info and pedantic too); an E: line, or lintian failing, fails the test
  rc=0; lintian --display-info --pedantic --tag-display-limit 0 "$d" >"$tmp/lintian-$p.txt" 2>&1 || rc=$?
  cat "$tmp/lintian-$p.txt"
  ! grep -q "^E: " "$tmp/lintian-$p.txt" || fail "lintian reports errors for $p (above)"
  [ "$rc" -eq 0 ] || fail "lintian failed on $p (rc $rc, above)"
  dpkg-deb --contents "$d" | awk '{print $NF}' >"$tmp/contents-$p.txt"
  for f in "./usr/share/doc/$p/copyright" "./usr/share/doc/$p/changelog.Debian.gz"; do
    grep -qxF "$f" "$tmp/contents-$p.txt" || fail "$p has no $f"
  done
  dpkg-deb --fsys-tarfile "$d" | tar -xO "./usr/share/doc/$p/copyright" | cmp - "$src/packaging/copyright" ||
    fail "$p's copyright is not packaging/copyright"
  dpkg-deb --fsys-tarfile "$d" | tar -xO "./usr/share/doc/$p/changelog.Debian.gz" | gzip -dc |
    head -1 | grep -q "^ehpt ($debversion) " || fail "$p's changelog.Debian.gz does not start with version $debversion"
  # a synopsis and an extended description of at least two lines
  [ "$(dpkg-deb --field "$d" Description | wc -l)" -ge 3 ] || fail "$p has no extended description: $(dpkg-deb --field "$d" Description)"
done
suggests="$(dpkg-deb --field "$deb" Suggests)"
echo "ehpt Suggests: $suggests"
for s in rt-tests can-utils python3-can liblcm-bin; do
  grep -qw -- "$s" <<<"$suggests" || fail "ehpt's Suggests lacks $s: $suggests"
done
# the man page, rendered as man shows it: no groff warning, the help's commands and our sections
grep -qxF ./usr/share/man/man1/ehpt.1.gz "$tmp/contents-ehpt.txt" || fail "ehpt has no man page"
MANWIDTH=80 man --warnings -l "$tmp/root/usr/share/man/man1/ehpt.1.gz" >"$tmp/man.txt" 2>"$tmp/man.err" ||
  { cat "$tmp/man.err"; fail "man -l cannot render ehpt.1.gz"; }
[ ! -s "$tmp/man.err" ] || { cat "$tmp/man.err"; fail "man -l warns about ehpt.1.gz"; }
for want in "^NAME" "ehpt - electric and hybrid power-train plant models" "^SYNOPSIS" "^DESCRIPTION" \
            "^COMMANDS" "^EXIT STATUS" "^FILES" "/usr/share/ehpt/scenarios/" "^ENVIRONMENT" "EHPT_SCENARIOS" \
            "^EXAMPLES" "ehpt run ev_nedc"; do
  grep -q -- "$want" "$tmp/man.txt" || { cat "$tmp/man.txt"; fail "the rendered man page has no '$want'"; }
done
# the page's commands (packaging/ehpt.h2m) are exactly those of `ehpt --help`
"$tmp/root/usr/bin/ehpt" --help | sed -n '/^commands:/,/^$/p' | sed -nE 's/^  ([a-z]+)( [A-Z_]+)? .*/\1/p' | sort >"$tmp/help-commands.txt"
sed -n '/^COMMANDS/,/^EXIT STATUS/p' "$tmp/man.txt" | sed -nE 's/^ {7}([a-z]+)( [A-Z_]+)?( .*)?$/\1/p' | sort >"$tmp/man-commands.txt"
[ "$(wc -l <"$tmp/help-commands.txt")" -ge 9 ] || fail "ehpt --help lists only $(wc -l <"$tmp/help-commands.txt") commands"
diff "$tmp/help-commands.txt" "$tmp/man-commands.txt" || fail "the man page's commands (>) are not ehpt --help's (<): packaging/ehpt.h2m"
echo "man ehpt: $(wc -l <"$tmp/man.txt") lines, the $(wc -l <"$tmp/man-commands.txt") commands of ehpt --help"
# stripped binaries (in the packages; the build tree keeps its symbols)
file "$tmp/root/usr/bin/ehpt" | tee "$tmp/file.txt"
grep -q ", stripped" "$tmp/file.txt" || fail "the packaged ehpt is not stripped"
if [[ " ${packages[*]} " == *" python3-ehpt "* ]]; then
  file "$tmp/root"/usr/lib/python3/dist-packages/ehpt*.so | tee "$tmp/file.txt"
  grep -q ", stripped" "$tmp/file.txt" || fail "the packaged Python module is not stripped"
fi
# ehpt-dev: the static libraries and the CMake package under the multiarch folder, nothing in /usr/lib itself
for f in "./usr/lib/$multiarch/libehpt_hil.a" "./usr/lib/$multiarch/libehpt_plant.a" \
         "./usr/lib/$multiarch/cmake/ehpt/ehptConfig.cmake"; do
  grep -qxF "$f" "$tmp/contents-ehpt-dev.txt" || fail "ehpt-dev has no $f"
done
! grep -E '^\./usr/lib/[^/]+\.a$|^\./usr/lib/cmake/' "$tmp/contents-ehpt-dev.txt" ||
  fail "ehpt-dev has libraries outside /usr/lib/$multiarch"
# the example ECUs, as in the source tree
examples="$tmp/root/usr/share/doc/ehpt/examples"
for pair in pycan_ecu.py:tools/pycan_ecu.py ehpt_dbc.py:tools/ehpt_dbc.py mbecu2_ecu.py:python/examples/mbecu2_ecu.py shev_ems.py:python/examples/shev_ems.py \
            lcm_ecu.cpp:examples/lcm_ecu.cpp embed/CMakeLists.txt:examples/embed/CMakeLists.txt \
            embed/main.cpp:examples/embed/main.cpp README.md:packaging/examples-README.md \
            own_dbc/vcu.dbc:examples/own_dbc/vcu.dbc own_dbc/vcu.binding.toml:examples/own_dbc/vcu.binding.toml \
            own_dbc/vcu_ecu.py:examples/own_dbc/vcu_ecu.py; do
  cmp "$examples/${pair%%:*}" "$src/${pair#*:}" || fail "the packaged example ${pair%%:*} is not ${pair#*:}"
done
# the unpacked CAN ECU finds the package's DBC by itself (the source tree hidden), on a virtual bus
"${hidden[@]}" /usr/bin/python3 "$examples/pycan_ecu.py" --interface virtual --idle-timeout 0.2 >"$tmp/pycan.txt" 2>&1 ||
  { cat "$tmp/pycan.txt"; fail "the packaged pycan_ecu.py does not start"; }
grep -q "stopped: idle" "$tmp/pycan.txt" || { cat "$tmp/pycan.txt"; fail "the packaged pycan_ecu.py: $(cat "$tmp/pycan.txt")"; }
echo "install, embed, Python, Debian packages and lintian: ok"
