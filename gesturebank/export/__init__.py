"""Exports: a dataset's clips or an angles CSV in other tools' formats (`gesturebank export`).

bvh: Pepper's upper body driven by the 11 angles (`pepper_bvh`) and the person's 3D joints
(`person_bvh`); trc: the 3D joints as OpenSim/Pose2Sim markers (`trc`); csv: the angle timeline
every command reads (`robot.timeline`); naoqi: names / angle lists / time lists for
`ALMotion.angleInterpolation`, as JSON plus a small script (`naoqi`). The glue is the command's,
`gesturebank.cli.export`.
"""
