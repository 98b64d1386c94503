"""Compute backends: :mod:`.base` is the interface; :mod:`.local` (a process pool), :mod:`.dask`
(a Dask cluster) and :mod:`.inline` (threads of the service) implement it, each imported only
when :mod:`service.jobs.factory` builds it."""
