"""NC posts (floor 6: imports ``machine``, ``toolpath`` and below; never the add-on).

``export`` (paths → program file and report; ``POSTS`` names the posts, ``get_post`` returns
one), ``blocks`` (the one block stream every post writes: poses solved for a machine),
``common`` (context, number formatting, header, atomic writing), ``tcp`` (checks shared by
the TCP posts), and one module per controller: ``linuxcnc``, ``fanuc``, ``siemens``,
``heidenhain``, ``apt``. Each controller module has ``NAME``, ``TCP``, ``INDEXABLE``,
``check(machine)`` and ``write(ctx) -> str``.
"""
