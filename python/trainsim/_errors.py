class TrainsimError(Exception):
    """An error of trainsim, with its message as trainsim prints it (file, line, group,
    key and value for a bad deck) and its code (`code`: 1 input, 2 file, 3 numeric,
    4 internal, 5 interrupted, 6 misuse of the interface)."""

    def __init__(self, message, code=1):
        super().__init__(message)
        self.message = message
        self.code = code
