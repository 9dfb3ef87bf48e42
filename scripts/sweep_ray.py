"""A sweep on a Ray cluster: one Ray task per run (`cosim sweep --only`),
then the table (docs/sweeps.md). Every node needs `cosim` and
`cosim-server` on its PATH and the sweep's files at the same paths (a
shared file system), as Ray's own job scripts do.

    python3 scripts/sweep_ray.py FILE OUT [--address auto]
"""

import argparse
import subprocess

import ray


@ray.remote(num_cpus=1)
def one(file, out, index):
    done = subprocess.run(
        ["cosim", "sweep", file, "--out", out, "--only", str(index), "--parallel", "1"],
        capture_output=True,
        text=True,
    )
    return index, done.returncode, done.stderr[-2000:]


def main():
    p = argparse.ArgumentParser()
    p.add_argument("file")
    p.add_argument("out")
    p.add_argument("--address", default=None)
    a = p.parse_args()
    listed = subprocess.run(
        ["cosim", "sweep", a.file, "--out", a.out, "--list"],
        capture_output=True, text=True, check=True,
    ).stdout.splitlines()
    ray.init(address=a.address)
    for index, code, err in ray.get([one.remote(a.file, a.out, i) for i in range(len(listed))]):
        if code != 0:
            print(f"run {index}: exit {code}\n{err}")
    subprocess.run(["cosim", "sweep", a.file, "--out", a.out, "--table"], check=True)


if __name__ == "__main__":
    main()
