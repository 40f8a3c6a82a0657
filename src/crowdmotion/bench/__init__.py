"""Side-by-side benchmarks shipped with the package, so ``crowdmotion bench METHOD`` runs
them on any install: ours against the paper's algorithm in plain Python and against peer
libraries (``pip install "crowdmotion[bench]"``; a peer that is not installed is left out
of the table, not an error). ``benchmarks/bench_*.py`` in the repository call the same code.
"""
