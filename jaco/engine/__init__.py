"""The engine: what every planner is made of and the loop that runs it.

The five concepts (docs/architecture.md, "Architecture"): the grid as a :class:`~.problem.Problem`
(:mod:`.problem`), hyperparameters as :class:`~.params.Params` (:mod:`.params`), pheromone rules
as ``(init, update)`` pairs (:mod:`.pheromone`), a planner as a :class:`~.planner.Planner`
(:mod:`.planner`, with :mod:`.heuristics`, :mod:`.schedules`, :mod:`.cost` and the construction
steps of :mod:`.colony` on the ant walk of :mod:`.walk`), and the run (:mod:`.run`, whose outcome
is a :class:`~.result.Result`, :mod:`.result`). The engine takes planners as objects: it never
imports the planners, the registry or anything above them.
"""

from .. import _submodules_on_access

__getattr__ = _submodules_on_access(__name__)
