"""A local Dask cluster of two workers renders a short walkthrough whose frames are the same
bits as one `irr --frames --shared-cache` process's.

Run from the repository root, after `cargo build -p irr-cli` (or with IRR naming a binary):
    PYTHONPATH=target/farm python3 -m unittest discover -s farm -v
"""

import os
import subprocess
import tempfile
import unittest
from pathlib import Path

import numpy as np
import OpenEXR

from irr_farm import main, walkthrough

ROOT = Path(__file__).resolve().parent.parent
IRR = os.environ.get("IRR", str(ROOT / "target" / "debug" / "irr"))
SCENE = str(ROOT / "assets" / "cornell-dolly.gltf")
# Six frames, key frames 0, 2, 4 and 5, split into two shards of two key frames; tiny images.
FRAMES = (0, 6)
SHARDS = 2
OPTIONS = ["--width", "40", "--height", "40", "--spp", "4", "--strata", "6x24",
           "--light-cache-paths", "20000", "--cache-every", "2", "--threads", "1"]


def channels(path: Path) -> dict:
    """Every channel of an EXR's first part, as raw bits."""
    with OpenEXR.File(str(path)) as f:
        return {name: np.ascontiguousarray(c.pixels).view(np.uint32).copy()
                for name, c in f.channels().items()}


class FarmTest(unittest.TestCase):
    def test_two_workers_give_the_single_process_frames(self):
        from dask.distributed import Client, LocalCluster

        self.assertTrue(os.path.exists(IRR), f"{IRR} is missing: cargo build -p irr-cli")
        with tempfile.TemporaryDirectory() as tmp:
            single = Path(tmp, "single")
            single.mkdir()
            subprocess.run([IRR, SCENE, *OPTIONS, "--frames", f"{FRAMES[0]}..{FRAMES[1]}",
                            "--shared-cache", "--shards", str(SHARDS),
                            "-o", str(single / "walk.####.exr")],
                           check=True, capture_output=True)
            with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                              dashboard_address=None) as cluster, Client(cluster) as client:
                # Chunks of two frames: three render tasks over the two workers.
                written = walkthrough(client, IRR, SCENE, FRAMES, str(Path(tmp, "farm", "walk.####.exr")),
                                      SHARDS, 2, ["--threads", "2", *OPTIONS[:-2]],
                                      work=str(Path(tmp, "work")))
                workers = len(client.scheduler_info()["workers"])
            self.assertEqual(workers, 2)
            exrs = sorted(p.name for p in written if p.suffix == ".exr")
            self.assertEqual(exrs, [f"walk.{f:04d}.exr" for f in range(*FRAMES)])
            for name in exrs:
                a, b = channels(single / name), channels(Path(tmp, "farm", name))
                self.assertEqual(sorted(a), sorted(b), name)
                for c in a:
                    self.assertTrue(np.array_equal(a[c], b[c]), f"{name}, channel {c}")
            # The frames are not all one image: the camera moves.
            first, last = channels(single / exrs[0]), channels(single / exrs[-1])
            self.assertFalse(all(np.array_equal(first[c], last[c]) for c in first))
            # The sequence's cache joins both shards' records.
            self.assertTrue(Path(tmp, "work", "sequence.irrc").stat().st_size
                            > Path(tmp, "work", "shard-0-of-2.irrc").stat().st_size)

    def test_the_command_line_takes_relative_paths_and_irr_options(self):
        """The command as the README gives it: relative output and work folders, irr's options
        after `--`; a missing binary is an error message and exit status 1, not a traceback."""
        with tempfile.TemporaryDirectory() as tmp:
            here = os.getcwd()
            os.chdir(tmp)
            try:
                status = main([SCENE, "--frames", "0..=2", "-o", "out/w.####.exr", "--irr", IRR,
                               "--work", "work", "--shards", "2", "--chunk", "2", "--", *OPTIONS])
                missing = main([SCENE, "--frames", "0..2", "-o", "x.exr", "--irr", "./no-irr-here"])
            finally:
                os.chdir(here)
            self.assertEqual(status, 0)
            self.assertEqual(missing, 1)
            for f in range(3):
                self.assertTrue(Path(tmp, "out", f"w.{f:04d}.exr").exists(), f)
                self.assertTrue(Path(tmp, "out", f"w.{f:04d}.png").exists(), f)
            self.assertTrue(Path(tmp, "work", "sequence.irrc").exists())


if __name__ == "__main__":
    unittest.main()
