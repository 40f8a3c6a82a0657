"""Run ``crowdmotion.bench.startup`` (the same as ``crowdmotion bench startup``); see its docstring."""

from crowdmotion.bench.startup import main

if __name__ == "__main__":
    main()
