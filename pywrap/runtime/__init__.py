"""What every job runs on: MPI, output folders, result files.

``parallel``   MPI communicators, rank-0 printing, broadcast of decisions
``relaunch``   ``--np N``: relaunch the command under ``mpirun``
``results``    atomic HDF5 series and tables (write, append, read)
``jobfolder``  job folders: configuration record, resume
``taskfarm``   independent tasks over MPI ranks (``mpi4py.futures``)

May import: :mod:`remote_trigger.analysis`, :mod:`remote_trigger.pywrap.config`.
"""
