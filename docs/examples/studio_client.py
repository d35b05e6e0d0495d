"""Drive a face from Python: one still through the render API, then a live stream of updates.

    facslab studio --port 8090 &
    pip install websockets            # the stream needs it; the render API is plain HTTP
    python3 studio_client.py http://127.0.0.1:8090/ out/

Writes out/still.png (AU 6+12 on wf1) and out/stream-NNN.png, one frame per update of a smile
that grows from nothing to E, and prints the round-trip time of each frame.
"""
import json
import pathlib
import sys
import time
import urllib.request

from websockets.sync.client import connect

base = sys.argv[1].rstrip("/") if len(sys.argv) > 1 else "http://127.0.0.1:8090"
out = pathlib.Path(sys.argv[2] if len(sys.argv) > 2 else "studio-out")
out.mkdir(parents=True, exist_ok=True)

# 1. One still: POST JSON, get the PNG that `facslab render 6+12 --identity wf1` writes.
request = urllib.request.Request(
    base + "/api/v1/render",
    data=json.dumps({"expression": "6+12", "identity": "wf1", "size": "485x480"}).encode(),
    headers={"Content-Type": "application/json"},
)
with urllib.request.urlopen(request) as response:
    (out / "still.png").write_bytes(response.read())

# 2. A stream: each update is answered by one frame (8-byte big-endian seq + PNG), in order.
updates = [f"6@{i / 10:.1f}+12@{i / 10:.1f}" for i in range(11)]
with connect(base.replace("http://", "ws://", 1) + "/api/v1/stream", max_size=None) as socket:
    for seq, expression in enumerate(updates):
        started = time.perf_counter()
        socket.send(json.dumps({"seq": seq, "expression": expression, "identity": "wf1", "size": "242x240"}))
        answer = socket.recv()
        if isinstance(answer, str):  # a refusal names the field and token
            sys.exit(f"update {seq} refused: {json.loads(answer)['error']}")
        assert int.from_bytes(answer[:8], "big") == seq
        (out / f"stream-{seq:03}.png").write_bytes(answer[8:])
        print(f"{seq:3} {expression:<16} {1000 * (time.perf_counter() - started):6.1f} ms")
print(f"wrote {len(updates) + 1} PNGs to {out}")
