"""Run ``crowdmotion.bench.rvo`` (the same as ``crowdmotion bench rvo``); see its docstring."""

from crowdmotion.bench.rvo import main

if __name__ == "__main__":
    main()
