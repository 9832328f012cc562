! SLICOT side of the peer comparison (benches/peers/slicot.sh, compare.py):
! identifies a state-space model with SLICOT's IB01AD (R factor + order) and
! IB01BD (A, C, B, D) from a raw binary record and prints ONE JSON line.
!
!   slicot_ib01 FILE [--meth N|M] [--alg C|Q] [--batch seq|one] [--block 65536]
!               [--order 4] [--nobr 20] [--inputs 2] [--outputs 2] [--qr-rows R]
!
! FILE: raw little-endian float64, row-major, one row per sample with the
! inputs first, then the outputs (u1,u2,y1,y2 by default): N*(m+l)*8 bytes,
! no header (numpy: np.ascontiguousarray(data, '<f8').tofile(FILE)).
!
! Options (defaults first):
!   --meth N   IB01AD METH='N' (N4SID), IB01BD METH='N' (N4SID A, C, B, D);
!          M   IB01AD METH='M' (MOESP), JOBD='N', IB01BD METH='C' (MOESP A, C,
!              N4SID B, D: the combination IB01BD documents for JOBD='N').
!   --alg C    Cholesky factor of the correlation matrix; Q: QR of the block
!              Hankel matrices.
!   --batch seq  sequential processing, BATCH='F','I',...,'L', CONCT='C', in
!              max(2, ceil(N/block)) blocks of near-equal length <= block:
!              only one block (plus the two N-by-m/l work copies) is in
!              memory; one: BATCH='O', the whole record in memory.
!   --qr-rows R  ALG='Q' only: rows of the Hankel segment held in DWORK
!              (default: the block length, SLICOT's recommended LDRWRK = NS).
! JOBD='N', CTRL='N', RCOND=0, TOL=-1 (largest gap; the order is then set to
! --order whatever IB01AD estimated, as SLICOT's TIB01BD example does), JOBCK='N'.
!
! Timing (system_clock, int64): identify_s is the time inside IB01AD (all
! blocks) and IB01BD; read_s is reading the file and unpacking the rows into
! the column-major U and Y arrays; total_s the whole program. Output:
!   {"identify_s":..,"read_s":..,"total_s":..,"n":..,"order_est":..,
!    "blocks":..,"a":[[..]],"b":..,"c":..,"d":..,...}
! On failure: {"error":"..."} and exit status 1.
program slicot_ib01
  use, intrinsic :: iso_fortran_env, only: int64, real64, error_unit
  implicit none
  integer, parameter :: dp = real64
  character(len=1024) :: path, arg
  character(len=1) :: meth_ad, meth_bd, alg, batch, jobd
  character(len=8) :: batch_mode
  integer :: m, l, nobr, norder, blk, qrows, nargs, i, k, ios, unit
  integer(int64) :: fsize, nt, base, extra, maxrows, row0, t0, t1, t2, rate, tstart
  integer :: nblk, ib, nsmp, nr, ldr, liwork, ldwork, n_est, n, ldu
  integer :: iwarn, info, iwarn_ad, iwarn_bd, iwarn_ad_any
  real(dp) :: t_read, t_id, t_total, rcond, tol, opt_ad, opt_bd
  real(dp), allocatable :: buf(:, :), u(:, :), y(:, :), r(:, :), sv(:), dwork(:)
  real(dp), allocatable :: a(:, :), b(:, :), c(:, :), d(:, :)
  real(dp) :: q(1, 1), ry(1, 1), s(1, 1), kk(1, 1)
  integer, allocatable :: iwork(:)
  logical :: bwork(1)
  external :: ib01ad, ib01bd

  call system_clock(tstart, rate)
  m = 2; l = 2; nobr = 20; norder = 4; blk = 65536; qrows = 0
  meth_ad = 'N'; alg = 'C'; batch_mode = 'seq'
  path = ''
  nargs = command_argument_count()
  i = 1
  do while (i <= nargs)
    call get_command_argument(i, arg)
    select case (trim(arg))
    case ('--meth')
      i = i + 1; call get_command_argument(i, arg); meth_ad = arg(1:1)
    case ('--alg')
      i = i + 1; call get_command_argument(i, arg); alg = arg(1:1)
    case ('--batch')
      i = i + 1; call get_command_argument(i, arg); batch_mode = arg(1:8)
    case ('--block')
      i = i + 1; call get_command_argument(i, arg); read (arg, *) blk
    case ('--qr-rows')
      i = i + 1; call get_command_argument(i, arg); read (arg, *) qrows
    case ('--order')
      i = i + 1; call get_command_argument(i, arg); read (arg, *) norder
    case ('--nobr')
      i = i + 1; call get_command_argument(i, arg); read (arg, *) nobr
    case ('--inputs')
      i = i + 1; call get_command_argument(i, arg); read (arg, *) m
    case ('--outputs')
      i = i + 1; call get_command_argument(i, arg); read (arg, *) l
    case default
      if (arg(1:2) == '--') call fail('unknown option ' // trim(arg))
      path = arg
    end select
    i = i + 1
  end do
  if (len_trim(path) == 0) call fail('usage: slicot_ib01 FILE [--meth N|M] [--alg C|Q] ' // &
      '[--batch seq|one] [--block 65536] [--order 4] [--nobr 20] [--inputs 2] [--outputs 2]')
  if (meth_ad /= 'N' .and. meth_ad /= 'M') call fail('--meth must be N or M')
  if (alg /= 'C' .and. alg /= 'Q') call fail('--alg must be C or Q')
  if (batch_mode /= 'seq' .and. batch_mode /= 'one') call fail('--batch must be seq or one')
  ! IB01BD: N4SID throughout for METH='N'; for MOESP (JOBD='N') the combined
  ! method 'C' (MOESP A, C; N4SID B, D), as in SLICOT's TIB01BD example.
  if (meth_ad == 'N') then
    meth_bd = 'N'
  else
    meth_bd = 'C'
  end if
  jobd = 'N'

  ! ---- the file: size -> number of samples, block plan
  call system_clock(t0)
  open (newunit=unit, file=trim(path), access='stream', form='unformatted', status='old', &
        action='read', convert='little_endian', iostat=ios)
  if (ios /= 0) call fail('cannot open ' // trim(path))
  inquire (unit=unit, size=fsize)
  if (mod(fsize, int(8 * (m + l), int64)) /= 0) call fail('file size is not a multiple of 8*(m+l)')
  nt = fsize / (8 * (m + l))
  if (nt < 2 * (m + l + 1) * nobr - 1) call fail('too few samples for NOBR')
  if (batch_mode == 'one') then
    nblk = 1
  else
    nblk = int(max(2_int64, (nt + blk - 1) / blk))
  end if
  base = nt / nblk
  extra = mod(nt, int(nblk, int64))
  maxrows = base
  if (extra > 0) maxrows = base + 1
  if (nblk > 1 .and. base < 2 * nobr) call fail('blocks shorter than 2*NOBR')
  call system_clock(t1)
  t_read = real(t1 - t0, dp) / real(rate, dp)

  ! ---- workspace from the documented formulas (IB01AD, IB01BD headers)
  nr = 2 * (m + l) * nobr
  ldr = max(nr, 3 * m * nobr)
  liwork = max(3, (m + l) * nobr, m * nobr + norder, m * (norder + l), l * nobr)
  ldwork = ib01ad_min() ! every case listed in IB01AD's LDWORK
  ldwork = max(ldwork, ib01bd_min())
  ldwork = max(ldwork, nr * nr) ! room for LAPACK's blocked code
  if (alg == 'Q') then
    ! workspace used: LDRWRK*NR + 4*(M+L)*NOBR with LDRWRK = LDWORK/NR - 2;
    ! recommended LDRWRK = NS (one inner cycle per block)
    if (qrows <= 0) qrows = int(maxrows)
    ldwork = max(ldwork, (qrows + 2) * nr + 4 * (m + l) * nobr)
  end if
  ldu = int(maxrows)
  allocate (buf(m + l, maxrows), u(maxrows, max(m, 1)), y(maxrows, l), r(ldr, nr), &
            sv(l * nobr), dwork(ldwork), iwork(liwork))
  allocate (a(norder, norder), b(norder, max(m, 1)), c(l, norder), d(l, max(m, 1)))
  dwork = 0; iwork = 0; r = 0

  rcond = 0.0_dp
  tol = -1.0_dp
  t_id = 0.0_dp
  iwarn_ad = 0; iwarn_ad_any = 0
  row0 = 0
  do ib = 1, nblk
    nsmp = int(base)
    if (ib <= extra) nsmp = nsmp + 1
    call system_clock(t0)
    read (unit, iostat=ios) buf(:, 1:nsmp)
    if (ios /= 0) call fail('read error')
    do k = 1, m
      u(1:nsmp, k) = buf(k, 1:nsmp)
    end do
    do k = 1, l
      y(1:nsmp, k) = buf(m + k, 1:nsmp)
    end do
    call system_clock(t1)
    if (nblk == 1) then
      batch = 'O'
    else if (ib == 1) then
      batch = 'F'
    else if (ib == nblk) then
      batch = 'L'
    else
      batch = 'I'
    end if
    call ib01ad(meth_ad, alg, jobd, batch, 'C', 'N', nobr, m, l, nsmp, u, ldu, y, ldu, &
                n_est, r, ldr, sv, rcond, tol, iwork, dwork, ldwork, iwarn, info)
    call system_clock(t2)
    t_read = t_read + real(t1 - t0, dp) / real(rate, dp)
    t_id = t_id + real(t2 - t1, dp) / real(rate, dp)
    if (info /= 0) then
      write (arg, '(a,i0,a,a,a,i0,a,i0)') 'IB01AD INFO=', info, ' BATCH=', batch, &
        ' block ', ib, ' of ', nblk
      call fail(trim(arg))
    end if
    if (iwarn /= 0) iwarn_ad_any = iwarn
    row0 = row0 + nsmp
  end do
  close (unit)
  iwarn_ad = iwarn
  opt_ad = dwork(1)
  n = norder
  if (n >= nobr) call fail('order must be < NOBR')

  call system_clock(t1)
  call ib01bd(meth_bd, 'A', 'N', nobr, n, m, l, int(min(nt, int(huge(1), int64))), r, ldr, &
              a, norder, c, l, b, norder, d, l, q, 1, ry, 1, s, 1, kk, 1, 0.0_dp, &
              iwork, dwork, ldwork, bwork, iwarn_bd, info)
  call system_clock(t2)
  t_id = t_id + real(t2 - t1, dp) / real(rate, dp)
  if (info /= 0) then
    write (arg, '(a,i0)') 'IB01BD INFO=', info
    call fail(trim(arg))
  end if
  opt_bd = dwork(1)
  call system_clock(t2)
  t_total = real(t2 - tstart, dp) / real(rate, dp)

  ! ---- one JSON line
  write (*, '(a)', advance='no') '{"identify_s":' // num(t_id) // ',"read_s":' // num(t_read) // &
    ',"total_s":' // num(t_total)
  write (*, '(a,i0,a,i0,a,i0,a,i0,a,i0)', advance='no') ',"n":', nt, ',"order_est":', n_est, &
    ',"blocks":', nblk, ',"block_rows":', maxrows, ',"nobr":', nobr
  write (*, '(a)', advance='no') ',"meth":"' // meth_ad // '/' // meth_bd // '","alg":"' // alg // &
    '","batch":"' // trim(batch_mode) // '"'
  write (*, '(a,i0,a,i0,a,i0,a,i0,a,i0)', advance='no') ',"iwarn_ib01ad":', iwarn_ad, &
    ',"iwarn_ib01ad_any":', iwarn_ad_any, ',"iwarn_ib01bd":', iwarn_bd, ',"ldwork":', ldwork, &
    ',"liwork":', liwork
  write (*, '(a)', advance='no') ',"ldwork_opt_ib01ad":' // num(opt_ad) // ',"ldwork_opt_ib01bd":' // &
    num(opt_bd) // ',"sv":'
  call put_vec(sv(1:min(l * nobr, 2 * norder + 2)))
  write (*, '(a)', advance='no') ',"a":'
  call put_mat(a)
  write (*, '(a)', advance='no') ',"b":'
  call put_mat(b(:, 1:m))
  write (*, '(a)', advance='no') ',"c":'
  call put_mat(c)
  write (*, '(a)', advance='no') ',"d":'
  call put_mat(d(:, 1:m))
  write (*, '(a)') '}'

contains

  !> Largest LDWORK minimum of IB01AD's header over the cases of this run
  !> (METH, ALG, BATCH 'F'/'I'/'L' with CONCT='C', or 'O').
  integer function ib01ad_min() result(w)
    integer :: ml
    ml = m + l
    w = 1
    if (alg == 'C') then
      w = max(w, (4 * nobr - 2) * ml)           ! F, I with CONCT='C'
      if (meth_ad == 'N') then
        w = max(w, 5 * ml * nobr + 1)           ! L or O
      else
        w = max(w, (4 * nobr - 2) * ml, 5 * l * nobr)
      end if
    else
      w = max(w, 4 * ml * nobr, 6 * ml * nobr, 5 * l * nobr, 5 * ml * nobr + 1)
      w = max(w, 4 * (nobr + 1) * ml * nobr)    ! I or L with CONCT='C'
    end if
  end function

  !> LDWORK minimum of IB01BD's header, JOB='A', JOBCK='N', M > 0.
  integer function ib01bd_min() result(w)
    integer :: ldw1n, ldw1m, ldw2, lnobr
    lnobr = l * nobr
    ldw1n = lnobr * norder + max((lnobr - l) * norder + 2 * norder + (2 * m + l) * nobr + l, &
            2 * (lnobr - l) * norder + norder * norder + 8 * norder, &
            norder + 4 * (m * nobr + norder) + 1, m * nobr + 3 * norder + l)
    ldw2 = lnobr * norder + m * nobr * (norder + l) * (m * (norder + l) + 1) + &
           max((norder + l)**2, 4 * m * (norder + l) + 1)
    ! METH='C': max(LDW1 of MOESP with JOB='C', LDW1 of N4SID) and N4SID's LDW2
    ldw1m = max(2 * (lnobr - l) * norder + 2 * norder, (lnobr - l) * norder + norder * norder + 7 * norder)
    w = max(ldw1n, ldw1m, ldw2)
  end function

  function num(x) result(str)
    real(dp), intent(in) :: x
    character(len=:), allocatable :: str
    character(len=40) :: tmp
    write (tmp, '(es25.17e3)') x
    str = trim(adjustl(tmp))
  end function

  subroutine put_vec(v)
    real(dp), intent(in) :: v(:)
    integer :: p
    write (*, '(a)', advance='no') '['
    do p = 1, size(v)
      if (p > 1) write (*, '(a)', advance='no') ','
      write (*, '(a)', advance='no') num(v(p))
    end do
    write (*, '(a)', advance='no') ']'
  end subroutine

  subroutine put_mat(x)
    real(dp), intent(in) :: x(:, :)
    integer :: p
    write (*, '(a)', advance='no') '['
    do p = 1, size(x, 1)
      if (p > 1) write (*, '(a)', advance='no') ','
      call put_vec(x(p, :))
    end do
    write (*, '(a)', advance='no') ']'
  end subroutine

  subroutine fail(msg)
    character(len=*), intent(in) :: msg
    write (*, '(a)') '{"error":"' // msg // '"}'
    write (error_unit, '(a)') 'slicot_ib01: ' // msg
    error stop 1
  end subroutine

end program slicot_ib01

!> SB02QD and SB02SD (reached from IB01BD through the Riccati solver of
!> JOBCK='K', not used here) pass an external SELECT to DGEES with
!> SORT='Not ordered', so it is never called; SLICOT ships no such function.
logical function select(wr, wi)
  use, intrinsic :: iso_fortran_env, only: real64
  implicit none
  real(real64), intent(in) :: wr, wi
  select = .false.
  if (wr /= wr .or. wi /= wi) select = .false.
end function select
