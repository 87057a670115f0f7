!> `trainsim --help` and `trainsim CMD --help`: the usage of the program and of each command.
module trainsim_cmd_help
   use trainsim_version, only: version_string
   implicit none
   private

   public :: usage, command_usage, continue_usage

contains

   subroutine usage(unit)
      integer, intent(in) :: unit
      write (unit, '(a)') 'trainsim '//version_string//' - drive trains with clearances (successor to TRAIN, Cook 1989)', &
         '', &
         'usage:', &
         '  trainsim run DECK [-o FILE | --no-output] [--set TARGET.KEY=VALUE ...] [--strict]', &
         '                                integrate the train in DECK; write the HDF5 history', &
         '                                (to FILE, else to the deck''s &run output). --set changes a', &
         '                                deck value (TARGET: node/element id, run, or GROUP#K) or a', &
         '                                derived one (GEAR.mesh_frequency, .settle_cycles, .measure_cycles,', &
         '                                .settle_max_cycles);', &
         '                                --no-output (or -o -): no history file, even if the deck names one;', &
         '                                --strict: the deck''s plausibility warnings (unit slips) are errors', &
         '  trainsim sweep DECK [-o FILE] [--set ...] [--resume] [--progress S] [--strict]', &
         '                                every run of the deck''s &sweep groups (serial, or under', &
         '                                mpirun -np N) into one HDF5 sweep file (default DECK_sweep.h5);', &
         '                                re-running it (or --resume) completes a sweep that was stopped;', &
         '                                progress on stderr every S seconds (default 5; 0: every run)', &
         '  trainsim runup DECK [--from F1 --to F2 --rate R] [--mesh ID] [--cycles M] [-o FILE]', &
         '                                a speed ramp from F1 to F2 teeth/s (or the deck''s &runup), the', &
         '                                mesh''s TE and force in mesh orders per M cycles, as a sweep file', &
         '  trainsim modes DECK [--closed] [--zone single|two-pair|initial] [--stiffest] [--preload]', &
         '                                natural frequencies and mode shapes of the linearised train,', &
         '                                and its RK4 step limit. Linearised as the run starts, or:', &
         '                                --closed    every clearance closed (contact stiffness counts)', &
         '                                --zone Z    every spur gear in its single-pair or two-pair', &
         '                                            zone (helical: shortest/longest contact lines),', &
         '                                            or the zone it starts in (initial, the default)', &
         '                                --stiffest  = --closed --zone two-pair: the stiffest state a', &
         '                                            run can reach (what `run` checks dt against)', &
         '                                --preload   about the static wind-up under the loads (contacts', &
         '                                            closed on their loaded faces; its angles printed)', &
         '  trainsim periodic DECK [--period-count K] [--segments M] [--transient N] [--tol TOL] [-o FILE]', &
         '                                the periodic orbit under periodic forcing by shooting: its', &
         '                                convergence, Floquet multipliers, stability, grazing, metrics', &
         '  trainsim continue DECK --param KEY=FROM:TO [-o F]  the periodic orbit continued, through folds', &
         '  trainsim gear --teeth N1 [N2] (--diametral-pitch P | --module M) --face-width F [...]', &
         '                                spur gear constants (App. E) and a deck fragment', &
         '  trainsim key --diameter D --key-length L [--fit tight|loose|average|all] [...]', &
         '                                keyed-joint stiffness curve (Ch. IV) and a deck fragment', &
         '  trainsim worm --starts Z1 --teeth Z2 (--module M | --diametral-pitch P) --friction MU [...]', &
         '                                worm pair: ratio, lead angle, efficiencies, self-locking', &
         '  trainsim planetary --teeth-sun ZS --teeth-planet ZP --planets N [...]', &
         '                                planetary stage: ratios (Willis), assembly, mesh phases', &
         '  trainsim export FILE.h5 QUANTITY ... | --events | --metrics | --summary json | --spectrum', &
         '                                CSV/JSON of a history (scripts/trainsim_export.py --help)', &
         '  trainsim plot FILE.h5 Y ... [--x X] | --te GEAR | --te-spectrum GEAR | --overview [ID]  -o OUT', &
         '                                figures of a history or a sweep (scripts/trainsim_plot.py --help)', &
         '  trainsim diagram DECK -o OUT.svg|png|pdf [--json FILE] [--set ...]', &
         '                                the train as a block diagram, from the deck alone', &
         '  trainsim fmu DECK -o TRAIN.fmu [--input INPUT ...] [--fmi 3|2]', &
         '                                the train as an FMI 3.0/2.0 co-simulation FMU (docs/fmu.md)', &
         '  trainsim --help | --version', &
         '', &
         'exit status: 0 success, 1 the run (or a run of the sweep) failed (numerics), 2 bad input or file,', &
         '             130 / 143 interrupted by SIGINT / SIGTERM (a run keeps its history so far, marked', &
         '             interrupted)', &
         'deck format: man trainsim; docs/deck.md (installed in share/doc/trainsim)'
   end subroutine usage

   !> `trainsim CMD --help`: the usage of one command.
   subroutine command_usage(cmd, unit)
      character(len=*), intent(in) :: cmd
      integer, intent(in) :: unit
      select case (cmd)
      case ('run')
         write (unit, '(a)') 'usage: trainsim run DECK [-o FILE | --no-output] [--set TARGET.KEY=VALUE ...]', '', &
            'Integrate the train in DECK from t_start to t_end of its &run group. Prints the', &
            'element parameters as used, a warning if dt exceeds the RK4 stability limit, and', &
            'a summary (steps, events, energy balance, element extremes, final state).', '', &
            '  -o, --output FILE  write the HDF5 history to FILE (else to &run output, if set);', &
            '                     only a regular file is replaced', &
            '  --no-output, -o -  write no history file, even if the deck names one', &
            '  --set T.KEY=VALUE  change a deck value: T is a node or element id, run, or GROUP#K', &
            '                     (e.g. mesh.half_backlash=2e-4, run.t_end=0.1, load#2.value=-500),', &
            '                     or a derived one (GEAR.mesh_frequency, .settle_cycles, .measure_cycles,', &
            '                     .settle_max_cycles)', &
            '  -h, --help         this text', '', &
            'A run longer than 2 s prints its progress on stderr: one line rewritten in place on a', &
            'terminal, a line every 10 s otherwise (TRAINSIM_PROGRESS_INTERVAL=S: every S seconds).', '', &
            'exit status: 0 success, 1 the run failed (numerics), 2 bad input or file,', &
            '             130 / 143 interrupted by SIGINT / SIGTERM: the history up to the last output', &
            '             time reached is kept, marked interrupted (root attribute status)'
      case ('sweep')
         write (unit, '(a)') 'usage: trainsim sweep DECK [-o FILE] [--set TARGET.KEY=VALUE ...] [--resume] [--progress S]', '', &
            'Every run of the &sweep groups of DECK, serially or under mpirun -np N (rank 0 hands', &
            'out runs on request), into one HDF5 sweep file (default DECK_sweep.h5). Running the', &
            'same command again (or --resume) makes only the runs still missing.', '', &
            '  -o, --output FILE  the sweep file', &
            '  --set T.KEY=VALUE  as for run, applied to every run', &
            '  --resume           complete the sweep in FILE (the default when FILE holds this sweep)', &
            '  --progress S       a progress line on stderr every S seconds (0: every run)', &
            '  -h, --help         this text', '', &
            'exit status: 0 every run ok, 1 some run failed (recorded in the file), 2 bad input or file', &
            '             (or FILE written by another sweep now), 130 / 143 stopped by SIGINT / SIGTERM', &
            '             (the runs made are recorded; the same command resumes)'
      case ('modes')
         write (unit, '(a)') 'usage: trainsim modes DECK [--closed] [--zone single|two-pair|initial] [--stiffest]', '', &
            'Natural frequencies and mode shapes of the linearised train, and its RK4 step limit.', &
            'Linearised as the run starts, or:', '', &
            '  --closed    every clearance closed (contact stiffness counts)', &
            '  --zone Z    every spur gear in its single-pair or two-pair zone (helical: shortest/', &
            '              longest contact lines), or the zone it starts in (initial, the default)', &
            '  --stiffest  = --closed --zone two-pair: the stiffest state a run can reach', &
            '  -h, --help  this text', '', &
            'exit status: 0 success, 2 bad input or file'
      case ('periodic')
         write (unit, '(a)') 'usage: trainsim periodic DECK [--period-count K] [--period T] [--segments M] [--transient N]', &
            '                         [--tol TOL] [--monodromy auto|saltation|fd] [--set TARGET.KEY=VALUE ...] [-o FILE]', '', &
            'The periodic state under periodic forcing (a mesh frequency, a sine load) by shooting: Newton on', &
            'P(x) - x after a transient, the monodromy by saltation matrices (auto: rk4, no stick-slip) or by', &
            'differences (docs/periodic.md). Prints convergence, orbit, multipliers, stability, grazing, metrics.', '', &
            '  --period-count K   the orbit repeats after K forcing periods (default 1; K > 1: subharmonic)', &
            '  --period T         the forcing period in s (default: settle_period, a mesh period, a sine''s)', &
            '  --segments M       multiple shooting: M segments of the K periods (default 1)', &
            '  --transient N      map applications before Newton starts (default 10, K periods each)', &
            '  --tol TOL          convergence: ||P(x) - x|| <= TOL of the state scale (default 1e-10)', &
            '  -o FILE            the orbit''s run as a history, with the group /periodic', &
            '  -h, --help         this text', '', &
            'exit status: 0 converged, 1 no orbit found (the reason printed) or the run failed, 2 bad input'
      case ('gear')
         write (unit, '(a)') 'usage: trainsim gear --teeth N1 [N2] (--diametral-pitch P | --module M) --face-width F [...]', &
            '   or: trainsim gear DECK [--mesh ID] [--points N] [-o TABLE] [--plot OUT.png]  (mesh stiffness, static TE)', '', &
            'Spur gear constants from the geometry (App. E, eqs. 3.9 and 3.12): radii, addendum, length of', &
            'action, base pitch, contact ratio, approach angle, gear ratio, pitch-disk inertias, mesh', &
            'stiffness, and a deck fragment in TRAIN''s seven constants. Implausible geometry (a unit slip)', &
            'is an error that names the likely slip.', '', &
            '  --teeth N1 [N2]            teeth of the driver (and the driven gear)', &
            '  --diametral-pitch P        1/in; or --module M in mm; --pressure-angle DEG (default 20)', &
            '  --face-width F             face width (in; m with --units si)', &
            '  --backlash B               total backlash along the line of action (in; m with --units si)', &
            '  --youngs-modulus E, --density RHO   material (steel by default)', &
            '  --stiffness-per-width KW, --stiffness K   the mesh stiffness instead of eq. 3.9', &
            '  --frequency HZ             the inertias that put each gear at HZ on the mesh', &
            '  --approach-velocity V      Goldsmith''s e and the damping D of eq. 3.12 at V', &
            '  --id ID, --units U         the fragment''s element id (its nodes ID_driver, ID_driven); in-lbf-s or si', &
            '  -h, --help                 this text', '', &
            'exit status: 0 success, 2 bad input'
      case ('diagram')
         write (unit, '(a)') 'usage: trainsim diagram DECK -o OUT.svg|png|pdf [--json FILE] [--set TARGET.KEY=VALUE ...]', '', &
            'The train of DECK as a block diagram: nodes as blocks (kind, inertia), elements as', &
            'connectors (type, ratio, backlash or clearance, stiffness), loads, prescribed speeds and', &
            'motor voltages as arrows; every unconnected part is drawn as its own piece. The deck is', &
            'read and built as `run` does (a bad deck: exit 2, the same message); nothing is run.', &
            'Drawn by scripts/trainsim_diagram.py with matplotlib (no Graphviz needed).', '', &
            '  -o, --output OUT   the drawing; the format follows the extension', &
            '  --json FILE        also write the description the drawing is made from (- for stdout);', &
            '                     without -o only the description is written', &
            '  --set T.KEY=VALUE  as for run', &
            '  -h, --help         this text', '', &
            'exit status: 0 success, 2 bad input or file'
      case ('fmu')
         write (unit, '(a)') 'usage: trainsim fmu DECK -o TRAIN.fmu [--input INPUT ...] [--fmi 3|2]', '', &
            'The train of DECK as an FMI 3.0 (or 2.0) co-simulation FMU (docs/fmu.md): outputs NODE.phi and', &
            'NODE.w (every node''s angle and speed), inputs (--input), parameters by deck path (every', &
            'value of the deck''s &node, &element, &load and &run groups: Float64, Int32 or String as the', &
            'deck writes it). doStep runs the deck''s own integrator', &
            'with its event location; get/setFMUstate save and restore. The deck (with its table', &
            'files) and a Linux x86-64 binary go inside. The deck is read and built as `run` does', &
            '(a bad deck: exit 2, the same message). Packed by scripts/trainsim_fmu.py.', '', &
            '  -o, --output FILE  the FMU (.fmu)', &
            '  --input INPUT      an input: NODE or NODE.tau a torque on NODE (neither fixed nor held),', &
            '                     NODE.speed the speed of a node the deck drives (replacing its motion),', &
            '                     NODE.voltage a dc_motor''s voltage; beside those of &fmu inputs = ...', &
            '  --fmi 3|2          the FMI version (default 3)', &
            '  -h, --help         this text', '', &
            'exit status: 0 success, 2 bad input or file'
      case ('planetary')
         write (unit, '(a)') 'usage: trainsim planetary --teeth-sun ZS --teeth-planet ZP --planets N [...]', '', &
            'A simple planetary stage from its tooth counts: the ratio with each member held (the Willis', &
            'equation (w_s - w_c)/(w_r - w_c) = -(z_r/z_s)), the planets'' speed on the carrier, the', &
            'assembly condition of N equally spaced planets ((z_s + z_r)/N whole), the mesh phases of', &
            'each planet, and a deck fragment for the &planetary group.', '', &
            '  --teeth-sun ZS, --teeth-planet ZP   teeth of the sun and of each planet', &
            '  --teeth-ring ZR            teeth of the ring (checked: ZS + 2 ZP; computed if not given)', &
            '  --planets N                planets on the carrier, equally spaced', &
            '  --module M                 module in mm; or --diametral-pitch P in 1/in (for the fragment)', &
            '  --pressure-angle DEG       default 20', &
            '  --id ID, --units U         the fragment''s stage id; in-lbf-s (default) or si', &
            '  -h, --help                 this text', '', &
            'exit status: 0 success, 2 bad input'
      case ('worm')
         write (unit, '(a)') 'usage: trainsim worm --starts Z1 --teeth Z2 (--module M | --diametral-pitch P) '// &
            '(--worm-diameter D1 | --diameter-factor Q) --friction MU [...]', '', &
            'A cylindrical worm pair from its geometry: ratio z2/z1, lead angle (tan gamma = z1 m / d1),', &
            'friction angle (tan rho'' = mu / cos alpha_n), forward and backward mesh efficiencies,', &
            'self-locking (backward efficiency <= 0), and a deck fragment for the worm_gear element.', '', &
            '  --starts Z1, --teeth Z2    threads of the worm, teeth of the wheel', &
            '  --module M                 axial module in mm; or --diametral-pitch P in 1/in', &
            '  --worm-diameter D1         worm pitch diameter (in; m with --units si); or', &
            '  --diameter-factor Q        D1 = Q * module', &
            '  --pressure-angle DEG       normal pressure angle, default 20', &
            '  --friction MU              coefficient of friction in the mesh', &
            '  --stiffness K              mesh stiffness for the fragment (force/length on the wheel)', &
            '  --id ID, --units U         the fragment''s element id; in-lbf-s (default) or si', &
            '  -h, --help                 this text', '', &
            'exit status: 0 success, 2 bad input'
      case ('key')
         write (unit, '(a)') 'usage: trainsim key --diameter D --key-length L [--fit tight|loose|average|all] [...]', '', &
            'The keyed-joint stiffness curve of Ch. IV (eqs. 4.35-4.37): torque, key force, lineal and', &
            'angular stiffness for each fit, and a deck fragment.', '', &
            '  --diameter D               shaft diameter', &
            '  --key-length L             key length', &
            '  --key-width W, --key-height H, --clearance C   key section and play', &
            '  --fit F                    tight, loose, average or all (default)', &
            '  --torque-max T, --points N the range and resolution of the table', &
            '  --id ID, --units U         the fragment''s element id; in-lbf-s (default) or si', &
            '  -h, --help                 this text', '', &
            'exit status: 0 success, 2 bad input'
      end select
   end subroutine command_usage

   !> trainsim continue --help
   subroutine continue_usage(unit)
      integer, intent(in) :: unit
      write (unit, '(a)') 'usage: trainsim continue DECK --param TARGET.KEY=FROM:TO [--ds DS] [--ds-max DS] [--points N]', &
         '                         [--period-count K] [--transient N] [--set ...] [-o FILE [--resume]]', '', &
         'The periodic orbit followed from FROM towards TO by pseudo-arclength continuation, through folds', &
         '(docs/periodic.md "Continuation"): each point''s parameter, period, largest |mu|, stability and any', &
         'fold / period-doubling / Neimark-Sacker point located on the way. With -o FILE.h5 the branch is', &
         'written as it grows (HDF5, the sweep file''s layout: docs/periodic.md "The branch file"); --resume', &
         'goes on from its last committed point, ending as an uninterrupted run would, bit for bit.', '', &
         '  --ds DS, --ds-max DS  first and largest step (scaled arclength; defaults 0.005, 0.05)', &
         '  --points N            at most N points (default 400; the file''s slots)', &
         '  --ds-min DS           smallest step (default 1e-6); --corrector N  chord steps (default 8)', &
         '  --restarts N          where the corrector fails (or no orbit is found), store a failed point with', &
         '                        its reason and shoot the orbit again further on: the sweep goes on (default 0)', &
         '  --restart-step R      how much further, of |FROM| (default 0.01)', &
         '  --transient N, --newton N, --retries N  the shooting of the first orbit (and of a restart)', &
         '  --monodromy HOW       auto (saltation where the deck allows), saltation, fd (central differences)', &
         '  --smooth              no non-smooth corrector: stop at a contact-sequence change (grazing)', &
         '  --switch-pd           at the first period-doubling point, continue the doubled branch (2T)', &
         '                        (with -o FILE into FILE.pd2; resumed by -o FILE.pd2 --resume)', &
         '  -h, --help            this text', '', &
         'exit status: 0 the branch left the range, 1 it stopped early or a stretch failed (the reasons', &
         'printed and in the file), 2 bad input'
   end subroutine continue_usage
end module trainsim_cmd_help
