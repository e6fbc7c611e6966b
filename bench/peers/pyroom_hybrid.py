#!/usr/bin/env python3
"""pyroomacoustics hybrid (image sources + ray tracing) peer for
`frusta-bench reverb`.

Reads a JSON job on stdin, writes a JSON result on stdout (library chatter
goes to stderr).

Job:
    {"rooms": [{"name": "shoebox",
                "size": [lx, ly, lz],
                "walls": {"west": {"absorption": [8 bands], "scattering": [8 bands]},
                          "east": ..., "south": ..., "north": ..., "floor": ..., "ceiling": ...},
                "center_freqs": [63, 125, ..., 8000],
                "source": [x, y, z], "listener": [x, y, z],
                "max_order": 3, "rays": 8192, "length_s": 2.0,
                "fs": 48000, "c": 343.2}]}

`west`/`east` are the walls x = 0 and x = lx, `south`/`north` y = 0 and
y = ly, `floor`/`ceiling` z = 0 and z = lz (pyroomacoustics' ShoeBox names).

Result:
    {"rooms": [{"name", "seconds", "fs", "rir", "threads", "version",
                "receiver_radius_m", "hist_bin_s"} | {"name", "error"}, ...]}

`seconds` times `Room.compute_rir()` only: the image sources to
`max_order`, the ray tracing of the late part and the synthesis of the
response (pyroomacoustics' libroom is single-threaded). Ray tracing uses
the library's defaults (receiver radius 0.5 m, 4 ms histogram bins, energy
threshold 1e-7) with the job's ray count and length; no air absorption.
"""

import contextlib
import json
import os
import sys
import time

THREADS = 1


@contextlib.contextmanager
def stdout_to_stderr():
    """Sends everything written to fd 1 (C++ included) to stderr."""
    sys.stdout.flush()
    saved = os.dup(1)
    os.dup2(2, 1)
    try:
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)


def run(room_job):
    import pyroomacoustics as pra

    pra.constants.set("c", room_job["c"])
    freqs = room_job["center_freqs"]
    materials = {
        name: pra.Material(
            {"coeffs": wall["absorption"], "center_freqs": freqs},
            {"coeffs": wall["scattering"], "center_freqs": freqs},
        )
        for name, wall in room_job["walls"].items()
    }
    room = pra.ShoeBox(
        room_job["size"],
        fs=room_job["fs"],
        materials=materials,
        max_order=room_job["max_order"],
        air_absorption=False,
        ray_tracing=True,
        use_rand_ism=False,
    )
    room.set_ray_tracing(n_rays=room_job["rays"], time_thres=room_job["length_s"])
    room.add_source(room_job["source"])
    room.add_microphone(room_job["listener"])
    start = time.perf_counter()
    room.compute_rir()
    seconds = time.perf_counter() - start
    rir = room.rir[0][0]
    return {
        "name": room_job["name"],
        "seconds": seconds,
        "fs": room_job["fs"],
        "rir": [float(v) for v in rir],
        "threads": THREADS,
        "version": pra.__version__,
        "receiver_radius_m": 0.5,
        "hist_bin_s": 0.004,
    }


def main():
    job = json.load(sys.stdin)
    out = []
    for room_job in job["rooms"]:
        try:
            with stdout_to_stderr():
                out.append(run(room_job))
        except Exception as e:  # reported per room, the others still run
            out.append({"name": room_job.get("name"), "error": repr(e)})
    json.dump({"rooms": out}, sys.stdout)


if __name__ == "__main__":
    main()
