"""Run ``crowdmotion.bench.formation`` (the same as ``crowdmotion bench formation``); see its docstring."""

from crowdmotion.bench.formation import main

if __name__ == "__main__":
    main()
