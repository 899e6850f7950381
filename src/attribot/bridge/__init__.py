"""attribot.bridge"""
