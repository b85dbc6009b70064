"""The train-bridge system as numbers, without time stepping: the bridge (girders, piers,
supports, modes), the train and its generated vehicle kernels, the contact rows, the creep law, and
the assembled :class:`~svbi.runtime.model.system.Model` and its :class:`~svbi.runtime.model.system.State`."""
