"""The saved model: write, read, evaluate, prediction bands, and exports of the identified robot."""
