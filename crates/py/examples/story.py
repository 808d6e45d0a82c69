"""The whole story from Python only: record → infer → learn → execute, as `pbd demo` does.

    python story.py [OUT_DIR]

1. record: the scripted teacher sorts a red block into the right bin and a blue mug into the left bin;
2. infer: the robot explains the demonstration with its own schemas (§4.2);
3. learn: the procedural model of which features decide the bin (ch. 5);
4. execute: in a new arrangement (`sorting-demo`) of objects it never saw.
"""

import os
import sys

import numpy as np

import pbd

out = sys.argv[1] if len(sys.argv) > 1 else "pbd-story"
os.makedirs(out, exist_ok=True)

recording = pbd.record(
    os.path.join(out, "demo.mcap"),
    scene="sorting",
    script="sort",
    assign="red_block=bin-right,blue_mug=bin-left",
    seed=1,  # the seed `pbd demo` uses by default
    progress=True,
)
print(recording)

demo = pbd.Demonstration.open(os.path.join(out, "demo.mcap"))
print(demo, "— percept rate", round(1 / float(np.median(np.diff(demo.times))), 1), "Hz")

inference = pbd.infer(demo.path)
posterior = inference["file"]["inference"]["posterior"]
print("MAP schema:", posterior["map"])
print(inference)

model = pbd.learn([inference], output=os.path.join(out, "model.json"))
print(model.explain())

report = pbd.execute(model, scene="sorting-demo", seed=1, output=os.path.join(out, "run.mcap"), progress=True)
print(report)
print(f"placed {report['placed']}/{report['relevant']}")
