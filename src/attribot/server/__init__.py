"""attribot.server"""
