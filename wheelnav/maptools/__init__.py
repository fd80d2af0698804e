"""Map tools: ``wheelnav plan`` and ``wheelnav rooms``, the planner and the room segmentation
run on a map or site from the terminal, without the fleet (text, JSON or a picture)."""
