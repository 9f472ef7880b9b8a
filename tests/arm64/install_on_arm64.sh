#!/bin/sh
# Runs in the arm64 base image under qemu (tests/arm64): `pip install .` of the board side into a
# fresh venv, as on a Raspberry Pi, then the tracker extra into the same venv and a few frames of
# the sample video through the chain with each runtime in $RUNTIMES ($FRAMES frames).
# /src: the project (read-only); /out: results for the test to check.
# Under emulation every Python program runs tens of times slower, and what costs most is pip
# byte-compiling what it installs (its own ~800 modules in `python3 -m venv`'s ensurepip, then
# numpy's): so the venv is made without pip, Debian's pip wheel (the one ensurepip would
# install) runs from its file, and nothing is byte-compiled. What gets installed is the same.
set -eu
start=$(date +%s)
cp -r /src /tmp/project
python3 -m venv --without-pip /tmp/venv
pip_wheel=$(ls /usr/share/python-wheels/pip-*.whl)
pip() { /tmp/venv/bin/python "$pip_wheel/pip" "$@"; }
pip install -q --no-compile /tmp/project
echo "plain install: $(( $(date +%s) - start )) s" >>/out/times.txt
# (written aside, then renamed: the test reads it as soon as it appears)
/tmp/venv/bin/python - >/out/plain.json.part <<'PY'
import importlib.util, json, platform
print(json.dumps({
    "machine": platform.machine(),
    "missing": [m for m in ("cv2", "ai_edge_litert", "sklearn") if importlib.util.find_spec(m) is None],
}))
PY
mv /out/plain.json.part /out/plain.json
for stage in control translator features router; do
  /tmp/venv/bin/facesynth "$stage" --help >/dev/null
done
echo ok >/out/plain.ok
start=$(date +%s)
pip install -q --no-compile "/tmp/project[tracker]"
echo "tracker extra: $(( $(date +%s) - start )) s" >>/out/times.txt
pip list --format=json >/out/tracker-packages.json
for runtime in $RUNTIMES; do
  start=$(date +%s)
  /tmp/venv/bin/facesynth run --fast --max-frames "$FRAMES" --inference "$runtime" \
    --listen tcp/127.0.0.1:0 --out "/out/track-$runtime.jsonl" \
    >"/out/track-$runtime.json" 2>"/out/track-$runtime.log"
  echo "track $runtime, $FRAMES frames: $(( $(date +%s) - start )) s" >>/out/times.txt
done
echo ok >/out/done.ok
