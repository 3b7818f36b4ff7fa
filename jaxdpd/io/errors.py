"""The error raised for output files that cannot be read back."""


class RunFileError(ValueError):
    """A file is not a readable jaxdpd H5MD file: missing, truncated, corrupted, or
    written for another scene or version.  The message names the file and the part."""
