"""Reads an MCAP recording with the third-party `mcap` package (the
format's reference reader) and prints what the Rust test checks, as JSON:
per topic its schema name, schema and message encodings and message
count; the entities of the /scene message at LOG_TIME_NS; the force
of the /forces/normal/CONTACT message at that time; and the /joints/*
messages at that time, by topic."""

import json
import sys

from mcap.reader import make_reader

path, log_time, contact = sys.argv[1], int(sys.argv[2]), sys.argv[3]
out = {"topics": {}, "scene": None, "force": None, "joints": {}}
with open(path, "rb") as f:
    reader = make_reader(f)
    summary = reader.get_summary()
    for channel in summary.channels.values():
        schema = summary.schemas[channel.schema_id]
        out["topics"][channel.topic] = {
            "schema": schema.name,
            "schema_encoding": schema.encoding,
            "message_encoding": channel.message_encoding,
            "messages": summary.statistics.channel_message_counts.get(channel.id, 0),
        }
    joints = [t for t in out["topics"] if t.startswith("/joints/")]
    for schema, channel, message in reader.iter_messages(
        topics=["/scene", f"/forces/normal/{contact}"] + joints,
        start_time=log_time,
        end_time=log_time + 1,
    ):
        data = json.loads(message.data)
        if channel.topic == "/scene":
            out["scene"] = data["entities"]
        elif channel.topic.startswith("/joints/"):
            out["joints"][channel.topic] = data
        else:
            out["force"] = data
print(json.dumps(out))
