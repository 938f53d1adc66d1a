"""`caustica study` (not written yet: registers no command)."""


def add_parser(sub):
    return None


def run(args) -> int:
    raise NotImplementedError
