"""A signal the command line received, raised again where long loops step (cellgl.bake.core's
progress bars, every tile and frame): the first KeyboardInterrupt can be swallowed (a C
extension's import has printed it and gone on), and the work must still stop.

Standard library only and no imports: the command line loads it before anything else."""

#: the exception to raise (set by cellgl.cli's signal handler, cleared when the command ends)
pending: list = []


def check() -> None:
    """Raise the pending KeyboardInterrupt (or the CLI's Terminated), if any."""
    if pending:
        raise pending.pop()
