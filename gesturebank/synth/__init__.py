"""Ground truth by rendering: motion capture drawn as video from known cameras.

A BVH (read by `gesturebank.mocap`) becomes a figure of simple meshes with a face photo, hair,
ears and clothes (`figure`, `looks`), ray-cast on the CPU by open3d's Embree scene and shaded
(`raycast`), seen by pinhole cameras around it (`camera`), written as one video per camera with
speech, beside the exact truth: 3D joints, 2D projections, cameras, true Pepper angles
(`truth`, `take`). `score` compares a 2D detection with it. `gesturebank render` is the command.
"""
