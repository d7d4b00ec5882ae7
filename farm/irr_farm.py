#!/usr/bin/env python3
"""Render a walkthrough with one shared irradiance cache on a Dask cluster.

The work is irr's own, in three steps, each a set of `irr` commands that Dask's `distributed`
scheduler places on whichever worker is free:

1. the cache's shards: `irr SCENE --frames A..B --shared-cache --shards S --shard I --cache F`,
   one task per shard, each returning its file's bytes;
2. `irr cache merge` of the shard files, here on the client (a second's work): the sequence's
   cache, the same bytes whichever worker built which shard;
3. the frames, in chunks: `irr SCENE --frames a..b --shared-cache --cache F`, every worker
   reading the same cache; each task returns its frames' EXR and PNG bytes, which the client
   writes to the output pattern.

Every task runs in a temporary folder of its worker and hands its files back through Dask, so
the workers need the `irr` binary and the scene (with the buffers and images it names) at the
same paths as the client, and nothing else shared (paths among the options after `--`, such as
`--asset-root`, must be absolute: the tasks do not run in the client's folder). Same seed, same frames, bit for bit, as one
`irr --frames A..B --shared-cache --shards S` process: the test beside this file checks it.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path


def parse_frames(text: str) -> tuple[int, int]:
    """`A..B` (B excluded) or `A..=B`, as irr reads --frames: the first frame and one past the last."""
    m = re.fullmatch(r"\s*(\d+)\s*\.\.(=?)\s*(\d+)\s*", text)
    if not m:
        raise argparse.ArgumentTypeError(f"expected A..B or A..=B, e.g. 0..120, got '{text}'")
    a, b = int(m.group(1)), int(m.group(3)) + (1 if m.group(2) else 0)
    if b <= a:
        raise argparse.ArgumentTypeError(f"'{text}' holds no frame")
    return a, b


def run_irr(irr: str, argv: list[str], cwd: str) -> None:
    """Runs irr; a failure raises with irr's own message (its last lines of stderr)."""
    done = subprocess.run([irr, *argv], cwd=cwd, capture_output=True, text=True)
    if done.returncode != 0:
        tail = "\n".join(done.stderr.strip().splitlines()[-5:])
        raise RuntimeError(f"irr {' '.join(argv)} failed ({done.returncode}):\n{tail}")


def build_shard(irr: str, scene: str, frames: tuple[int, int], shards: int, index: int,
                options: list[str]) -> bytes:
    """Worker task: builds shard `index` of `shards` of the sequence's cache; its file's bytes."""
    with tempfile.TemporaryDirectory(prefix="irr-shard-") as tmp:
        shard = os.path.join(tmp, "shard.irrc")
        run_irr(irr, [scene, *options, "--frames", f"{frames[0]}..{frames[1]}",
                      "--shared-cache", "--shards", str(shards), "--shard", str(index),
                      "--cache", shard], tmp)
        return Path(shard).read_bytes()


def render_chunk(irr: str, scene: str, chunk: tuple[int, int], cache: bytes, pattern: str,
                 options: list[str]) -> dict[str, bytes]:
    """Worker task: renders frames `chunk` from the sequence's cache `cache`; every file it
    wrote (EXR, PNG, and any debug views), by name."""
    with tempfile.TemporaryDirectory(prefix="irr-frames-") as tmp:
        path = os.path.join(tmp, "sequence.irrc")
        Path(path).write_bytes(cache)
        out = os.path.join(tmp, "frames")
        os.mkdir(out)
        run_irr(irr, [scene, *options, "--frames", f"{chunk[0]}..{chunk[1]}",
                      "--shared-cache", "--cache", path, "-o", os.path.join(out, pattern)], tmp)
        return {name: Path(out, name).read_bytes() for name in sorted(os.listdir(out))}


def write_atomically(path: Path, data: bytes) -> None:
    """Writes `data` to `path` through a temporary file, synced and renamed into place (no half
    files, an earlier file kept until the new one is whole)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.close(fd)
        except OSError:
            pass
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def find_irr(irr: str) -> str:
    """The irr binary's absolute path: a bare name is looked up on PATH (as a shell would), a
    path made absolute; an error says which was not found."""
    found = shutil.which(irr) if os.sep not in irr else (irr if os.path.isfile(irr) else None)
    if found is None:
        raise RuntimeError(f"--irr: no irr binary at '{irr}' (install it, or name its path)")
    return os.path.abspath(found)


def walkthrough(client, irr: str, scene: str, frames: tuple[int, int], out: str, shards: int,
                chunk: int, options: list[str], work: str | None = None) -> list[Path]:
    """Renders frames `frames` of `scene` on `client`'s cluster to the pattern `out` (irr's
    `-o`, with `####` for the frame number); the files written, in order. `work` keeps the
    shard files and the sequence's cache (`sequence.irrc`) when given."""
    irr, scene = find_irr(irr), os.path.abspath(scene)
    out_path = Path(out).resolve()
    # pure=False: Dask gives every task a key of its own, so runs on a long-lived cluster never
    # share results.
    shard_futures = [client.submit(build_shard, irr, scene, frames, shards, i, options, pure=False)
                     for i in range(shards)]
    shard_bytes = client.gather(shard_futures)
    with tempfile.TemporaryDirectory(prefix="irr-merge-") as tmp:
        keep = Path(work).resolve() if work else Path(tmp)
        keep.mkdir(parents=True, exist_ok=True)
        names = []
        for i, data in enumerate(shard_bytes):
            name = keep / f"shard-{i}-of-{shards}.irrc"
            write_atomically(name, data)
            names.append(str(name))
        merged = keep / "sequence.irrc"
        run_irr(irr, ["cache", "merge", *names, "-o", str(merged)], str(keep))
        cache = merged.read_bytes()
    cache_future = client.scatter(cache, broadcast=True)
    chunks = [(a, min(a + chunk, frames[1])) for a in range(frames[0], frames[1], chunk)]
    frame_futures = [client.submit(render_chunk, irr, scene, c, cache_future, out_path.name,
                                   options, pure=False)
                     for c in chunks]
    written = []
    for files in client.gather(frame_futures):
        for name, data in files.items():
            target = out_path.with_name(name)
            write_atomically(target, data)
            written.append(target)
    return written


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description="Render a walkthrough with one shared irradiance cache on a Dask cluster.",
        usage="%(prog)s SCENE --frames A..B -o OUT [options] [-- irr options]",
        epilog="Options after `--` go to every irr command, e.g. -- --width 640 --spp 36 --cache-every 10",
    )
    parser.add_argument("scene", help="the glTF scene, at the same path on every worker")
    parser.add_argument("--frames", required=True, type=parse_frames, help="A..B or A..=B")
    parser.add_argument("-o", "--out", required=True,
                        help="output pattern, e.g. out/walk.####.exr (irr's -o)")
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--scheduler", help="a Dask scheduler's address, e.g. tcp://10.0.0.1:8786")
    where.add_argument("--local-workers", type=int, default=2,
                       help="without --scheduler: a local cluster of N worker processes (default 2)")
    parser.add_argument("--irr", default="irr", help="the irr binary, at the same path on every worker")
    parser.add_argument("--shards", type=int, default=2,
                        help="shards of the cache's construction (irr's --shards; part of the result)")
    parser.add_argument("--chunk", type=int, default=8, help="frames per render task (default 8)")
    parser.add_argument("--work", help="keep the shard files and sequence.irrc in this folder")
    argv = sys.argv[1:] if argv is None else argv
    # Everything after the first `--` goes to irr as it is.
    split = argv.index("--") if "--" in argv else len(argv)
    args = parser.parse_args(argv[:split])
    options = argv[split + 1:]
    if args.shards < 1 or args.chunk < 1:
        parser.error("--shards and --chunk must be at least 1")

    from dask.distributed import Client, LocalCluster

    if args.scheduler:
        client = Client(args.scheduler)
        cluster = None
    else:
        cluster = LocalCluster(n_workers=args.local_workers, threads_per_worker=1,
                               processes=True, dashboard_address=None)
        client = Client(cluster)
    try:
        written = walkthrough(client, args.irr, args.scene, args.frames, args.out, args.shards,
                              args.chunk, options, args.work)
    except (RuntimeError, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    print(f"wrote {len(written)} files for frames {args.frames[0]} to {args.frames[1] - 1}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
