"""closed_loop"""
