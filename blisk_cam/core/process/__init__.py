"""Operations: a part, its stock, a tool and options in; a tool path (and the stock after)
out (floor 7: may import every core package).

``operation`` (the life-cycle every operation follows: request → progress → result, with
per-stage times), ``blade_finish`` (LMC blade finishing, the first operation).
"""
