"""attribot.eval"""
