"""The wheeled Go1: joint and leg order, geometry and limits (constants), the USD asset in a Newton model (asset)."""
