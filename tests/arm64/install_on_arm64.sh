#!/bin/sh
# Runs in the arm64 base image under qemu (tests/arm64): `pip install .` of the board side into a
# fresh venv, as on a Raspberry Pi, then the tracker extra into the same venv and a few frames of
# the sample video through the chain with each inference runtime the tracker finds.
# /src: the project (read-only); /out: results for the test to check.
set -eu
start=$(date +%s)
cp -r /src /tmp/project
python3 -m venv /tmp/venv
/tmp/venv/bin/pip install -q /tmp/project
echo "plain install: $(( $(date +%s) - start )) s" >>/out/times.txt
/tmp/venv/bin/python - >/out/plain.json <<'PY'
import importlib.util, json, platform
print(json.dumps({
    "machine": platform.machine(),
    "missing": [m for m in ("cv2", "ai_edge_litert", "sklearn") if importlib.util.find_spec(m) is None],
}))
PY
for stage in control translator features router; do
  /tmp/venv/bin/facesynth "$stage" --help >/dev/null
done
echo ok >/out/plain.ok
start=$(date +%s)
/tmp/venv/bin/pip install -q "/tmp/project[tracker]"
echo "tracker extra: $(( $(date +%s) - start )) s" >>/out/times.txt
/tmp/venv/bin/pip list --format=json >/out/tracker-packages.json
for runtime in litert opencv; do
  start=$(date +%s)
  /tmp/venv/bin/facesynth run --fast --max-frames "$FRAMES" --inference "$runtime" \
    --listen tcp/127.0.0.1:0 --out "/out/track-$runtime.jsonl" \
    >"/out/track-$runtime.json" 2>"/out/track-$runtime.log"
  echo "track $runtime, $FRAMES frames: $(( $(date +%s) - start )) s" >>/out/times.txt
done
echo ok >/out/done.ok
