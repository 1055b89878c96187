"""From a validated scenario to runnable objects: robot, camera, sensor, task, law,
checked start (:func:`redservo.experiment.build.build.build`)."""
