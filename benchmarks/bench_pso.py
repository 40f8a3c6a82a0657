"""Run ``crowdmotion.bench.pso`` (the same as ``crowdmotion bench pso``); see its docstring."""

from crowdmotion.bench.pso import main

if __name__ == "__main__":
    main()
