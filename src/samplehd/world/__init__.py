"""The ground floor every stage shares: what the table, the robot's reach and the scene's bodies are.

- :mod:`~samplehd.world.layout`: table layout, table parts and ground-plane directions.
- :mod:`~samplehd.world.relations`: spatial relations between objects (left of, behind, ...).
- :mod:`~samplehd.world.bodies`: body naming and the model index of a compiled scene
  (:class:`~samplehd.world.bodies.SceneBodies`), object poses, boxes, footprints and contacts.
- :mod:`~samplehd.world.robot_info`: the robot's joints, fingers and TCP in a compiled model.
- :mod:`~samplehd.world.collision`: collision queries of arm configurations.
- :mod:`~samplehd.world.transforms`: rotation and pose helpers (quaternions, yaw, rotation vectors).
- :mod:`~samplehd.world.placement`, :mod:`~samplehd.world.free_spot`: the free-spot search's
  numbers, footprint rectangle test and the grid prediction the language constraints use.
- :mod:`~samplehd.world.reach`, :mod:`~samplehd.world.grasps`: reach and grasp feasibility queries.
- :mod:`~samplehd.world.planner_config`: the planner settings those queries share with the planner.
- :mod:`~samplehd.world.seeding`: how per-scene and per-episode seeds derive from a base seed.

Nothing here imports a stage above it (scene, language, tasks, motion, record, dataset, envs).
Modules are imported one by one (this package re-exports nothing) so that reading a layout never
loads MuJoCo.
"""
