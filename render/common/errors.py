"""The one exception type for bad user input."""


class InputError(ValueError):
    """Bad input data. The message is one line that names the file and the problem."""

    def __init__(self, path, problem):
        self.path = str(path)
        self.problem = problem
        super().__init__(f"{self.path}: {problem}")
