"""Pictures, videos and pages for slides and course pages, through a headless browser.

Nothing here is imported at start-up: the command line imports a job when it is asked
for, and ``--snapshot`` imports the app only while Chromium launches.
"""
