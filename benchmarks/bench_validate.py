"""Run ``crowdmotion.bench.validate`` (the same as ``crowdmotion bench validate``); see its docstring."""

from crowdmotion.bench.validate import main

if __name__ == "__main__":
    main()
