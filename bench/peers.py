"""Against peers: rays/s of tribench's fastest brute-force kernel vs trimesh and Embree, as ratios with CIs.

The measurement is ``tribench peers`` (tribench.harness.jobs.peers, whose docstring
says what is timed and how): Suzanne, 968 triangles, 512x512 camera, closest
hit; fresh worker processes pinned to one CPU with one BLAS thread, each
contender once per repetition in a random order; rays/s with 95% CIs over
processes and tribench's ratios over each peer, paired by process. This
script runs it so the bench folder lists every figure; ``tribench run`` puts
the same figures in the report when a peer is installed
(``pip install 'tribench[peers]'``).

    python bench/peers.py [--quick] [--camera 512x512] [--processes 5] [--reps 3] [--out FILE.csv]
"""

import sys

from tribench.cli.command import main

if __name__ == "__main__":
    sys.exit(main(["peers", *sys.argv[1:]]))
