"""Reads what an MCAP recording sends once (/shapes, /visuals) and its
first /tf with the third-party `mcap` package, and prints it as JSON for
the Rust test; each embedded model's bytes are written, base64-decoded,
to OUT_DIR/<n>.<ext> and named in place of the data."""

import base64
import json
import sys

from mcap.reader import make_reader

path, out_dir = sys.argv[1], sys.argv[2]
ext = {"model/vnd.collada+xml": "dae", "model/stl": "stl", "model/obj": "obj",
       "model/gltf-binary": "glb", "model/gltf+json": "gltf"}
out = {"once": {}, "tf": None, "tf_time": None, "counts": {}}
n = 0
with open(path, "rb") as f:
    for schema, channel, message in make_reader(f).iter_messages(log_time_order=True):
        out["counts"][channel.topic] = out["counts"].get(channel.topic, 0) + 1
        if channel.topic in ("/shapes", "/visuals"):
            data = json.loads(message.data)
            for e in data["entities"]:
                for m in e["models"]:
                    name = f"{out_dir}/{n}.{ext[m['media_type']]}"
                    n += 1
                    with open(name, "wb") as g:
                        g.write(base64.b64decode(m["data"]))
                    m["data"] = name
            out["once"][channel.topic] = {"log_time": message.log_time, "entities": data["entities"]}
        elif channel.topic == "/tf" and out["tf"] is None:
            out["tf"] = json.loads(message.data)["transforms"]
            out["tf_time"] = message.log_time
print(json.dumps(out))
